"""The element frame and coordinates that a body's replaced joints give (``make_compliant(..., replace_joints=...)``).

* :func:`replaced_and_kept`: which of the body's joints become the element's coordinates (all of them, or the
  ones named) and which stay joints with their own joint model;
* :func:`joint_frame`: the element frame the replaced joints suggest, by one rule (below);
* :func:`kept_directions`: the element directions a kept joint moves the body in (the element leaves them alone);
* :func:`missing_directions`: the element directions that need a joint added;
* :func:`too_many_dofs`: the redundant joints that would give the body more than six degrees of freedom;
* :func:`stops_from_ranges`: the replaced joints' ranges in element coordinates;
* :func:`axis_mismatch`: a replaced hinge (or slide) that ``K`` is not softest about (along);
* :func:`rest_from_springs`: the element's rest pose where the replaced joints' springs rest (``springref``).

**The element frame of replaced joints** (when neither ``site`` nor ``pos``/``quat`` gives it):

* its origin is the anchor of the first replaced hinge or ball joint (the body's origin for slides alone);
* **one hinge** (and no ball) among the replaced joints: the element's **z axis is the hinge's axis**, so that a
  stiffness from :mod:`mjflex.geometry` (whose notch hinges and leaf springs turn about their z axis) gives the
  hinge its compliant stiffness; x is the body axis most nearly perpendicular to the hinge (the first on a tie),
  made perpendicular; y completes the right-handed frame. **One slide** and no hinge or ball: z along the slide,
  x and y the same way;
* otherwise (a ball, or several hinges: a disc's three hinges, a spherical joint): the body's axes when every hinge
  and slide axis lies along one of them (a disc's axial rotation is then its z when the body's z is), else x along
  the first joint axis and y in the plane of the first two.

A hinge's angle is then the element's rotation-vector component about its axis exactly for rotation about it alone.
"""

import math

import mujoco
import numpy as np

from . import naming
from .notices import warn_likely_mistake

_T = mujoco.mjtJoint
HINGE, SLIDE, BALL, FREE = int(_T.mjJNT_HINGE), int(_T.mjJNT_SLIDE), int(_T.mjJNT_BALL), int(_T.mjJNT_FREE)
KIND = {HINGE: "hinge", SLIDE: "slide", BALL: "ball", FREE: "free"}
DOFS = {HINGE: 1, SLIDE: 1, BALL: 3, FREE: 6}
QPOS = {HINGE: 1, SLIDE: 1, BALL: 4, FREE: 7}  # numbers in qpos
DIRECTIONS = ("rx", "ry", "rz", "x", "y", "z")
#: An axis this close to an element axis (1 - |cos|) counts as along it.
ALIGNED = 1e-9
#: ``axis_mismatch`` warns when K about the replaced hinge's axis exceeds K's softest rotation by this factor.
SOFTEST_RATIO = 1.5


def body_joints(rigid, body_name) -> list[tuple[str, int]]:
    """``(name, id)`` of the body's joints in the compiled model, in order (``"#id"`` for an unnamed one)."""
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body_name)
    ids = range(rigid.body_jntadr[ib], rigid.body_jntadr[ib] + rigid.body_jntnum[ib])
    return [(mujoco.mj_id2name(rigid, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}", j) for j in ids]


def replaced_and_kept(rigid, body_name, replace_joints):
    """``(replaced, kept)``: the body's joints ``(name, id)`` that become the element's coordinates, and the others.

    ``replace_joints``: True (all of them), a joint's name or a list of names (those). Raises TypeError for
    anything else, ValueError for a name that is not a joint of the body (with the body's joints, or the body
    that has it), a repeated or empty list.
    """
    joints = body_joints(rigid, body_name)
    if replace_joints is True:
        return joints, []
    if isinstance(replace_joints, str):
        replace_joints = [replace_joints]
    if isinstance(replace_joints, (bool, int, float, dict, bytes)) or not hasattr(replace_joints, "__iter__"):
        raise TypeError(
            f"replace_joints must be True (all of body {body_name!r}'s joints), False, or the names of the joints to "
            f"replace (a list of str); got {replace_joints!r}"
        )
    names = list(replace_joints)
    if not names:
        raise ValueError(f"replace_joints=[] names no joint of body {body_name!r}; name some of "
                         f"{[n for n, _ in joints]}, or pass replace_joints=True for all")  # fmt: skip
    if not all(isinstance(n, str) for n in names):
        raise TypeError(f"replace_joints: joint names are str; got {names!r}")
    if len(set(names)) < len(names):
        raise ValueError(f"replace_joints names a joint twice: {names}")
    own = {n: j for n, j in joints}
    for n in names:
        if n not in own:
            j = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_JOINT, n)
            where = (f"; that is a joint of body {rigid.body(rigid.jnt_bodyid[j]).name!r}" if j >= 0 else
                     naming.suggestion(n, list(own), "joints of the body"))  # fmt: skip
            raise ValueError(f"replace_joints: {n!r} is not a joint of body {body_name!r} (its joints: "
                             f"{list(own)}){where}")  # fmt: skip
    return [(n, j) for n, j in joints if n in names], [(n, j) for n, j in joints if n not in names]


def too_many_dofs(rigid, body_name, added) -> str | None:
    """Why the body would get more than six dofs with the joints ``added`` (names of its redundant joints), or None."""
    joints = body_joints(rigid, body_name)
    total = sum(DOFS[int(rigid.jnt_type[j])] for _, j in joints) + len(added)
    if total <= 6:
        return None
    spans, owners, redundant = {"r": [], "t": []}, {"r": [], "t": []}, []
    for name, j in joints:
        kind = int(rigid.jnt_type[j])
        parts = {HINGE: [("r", rigid.jnt_axis[j])], SLIDE: [("t", rigid.jnt_axis[j])],
                 BALL: [("r", a) for a in np.eye(3)],
                 FREE: [("t", a) for a in np.eye(3)] + [("r", a) for a in np.eye(3)]}[kind]  # fmt: skip
        lost, shared = 0, []
        for k in ("r", "t"):
            axes = [a for kk, a in parts if kk == k]
            if axes and _rank(spans[k] + axes) < _rank(spans[k]) + len(axes):
                lost += _rank(spans[k]) + len(axes) - _rank(spans[k] + axes)
                shared += owners[k]
            spans[k] += axes
            owners[k] += [name] if axes else []
        if lost:
            redundant.append(f"{KIND[kind]} {name} ({lost} of its dofs already given by {', '.join(shared)})")
    return (
        f"body {body_name!r} would get {total} degrees of freedom (its joints and {len(added)} added for the element's "
        f"other directions), and MuJoCo allows at most 6: its joints are redundant: {'; '.join(redundant)}. Remove "
        "or merge the redundant joints first (one joint per direction), or give fewer directions="
    )


def joint_frame(rigid, body_name, ids) -> tuple[np.ndarray, np.ndarray]:
    """World pose ``(p_WE, R_WE)`` at ``qpos0`` of the element frame that the joints ``ids`` suggest (module rule)."""
    data = mujoco.MjData(rigid)
    mujoco.mj_kinematics(rigid, data)
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body_name)
    R_WB, p = data.xmat[ib].reshape(3, 3).copy(), data.xpos[ib].copy()
    rotational = [j for j in ids if rigid.jnt_type[j] in (HINGE, BALL)]
    if rotational:
        p = data.xanchor[rotational[0]].copy()
    hinges = [j for j in ids if rigid.jnt_type[j] == HINGE]
    slides = [j for j in ids if rigid.jnt_type[j] == SLIDE]
    balls = [j for j in ids if rigid.jnt_type[j] in (BALL, FREE)]
    if not balls and (len(hinges) == 1 or (not hinges and len(slides) == 1)):
        return p, _z_along(data.xaxis[(hinges or slides)[0]], R_WB)
    axes = [data.xaxis[j].copy() for j in ids if rigid.jnt_type[j] in (HINGE, SLIDE)]
    if all(np.abs(R_WB.T @ a).max() > 1 - ALIGNED for a in axes):
        return p, R_WB
    distinct = [axes[0]]
    for a in axes[1:]:
        if abs(abs(a @ distinct[0]) - 1) > ALIGNED:
            distinct.append(a)
            break
    if len(distinct) == 1:
        return p, _z_along(distinct[0], R_WB)
    x = distinct[0] / np.linalg.norm(distinct[0])
    y = distinct[1] - (distinct[1] @ x) * x
    y /= np.linalg.norm(y)
    return p, np.column_stack([x, y, np.cross(x, y)])


def _z_along(axis, R_WB):
    """Axes (columns, world frame) with z along ``axis`` and x the body axis most nearly perpendicular to it."""
    z = axis / np.linalg.norm(axis)
    x = R_WB[:, int(np.argmin(np.abs(R_WB.T @ z)))]
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def kept_directions(rigid, kept, R_BE) -> tuple[str, ...]:
    """The element directions that the kept joints ``(name, id)`` move the body in (the element leaves them alone).

    ``R_BE``: the element frame's axes in the body's frame. Raises ValueError for a kept hinge or slide that is not
    along an element axis (the element would measure part of its motion) or a kept free joint.
    """
    out = set()
    for name, j in kept:
        kind = int(rigid.jnt_type[j])
        if kind == FREE:
            raise ValueError(f"joint {name!r} is a free joint: it moves the body in every direction, and an element "
                             "beside it would measure its motion; replace it too, or none")  # fmt: skip
        if kind == BALL:
            out |= {"rx", "ry", "rz"}
            continue
        axis = R_BE.T @ rigid.jnt_axis[j]
        k = int(np.argmax(np.abs(axis)))
        if abs(axis[k]) < 1 - 1e-6:
            raise ValueError(
                f"{KIND[kind]} {name!r} is kept as a joint, but its axis {np.round(axis, 4).tolist()} (element frame) "
                "is not along an element axis: the element would measure part of its motion. Give an element frame "
                "with an axis along it (site=, or pos=/quat= with frame=), or replace it too"
            )
        out.add(("r" if kind == HINGE else "") + "xyz"[k])
    return tuple(d for d in DIRECTIONS if d in out)


def missing_directions(rigid, body_name, R_BE, directions) -> tuple[str, ...]:
    """The element directions of ``directions`` that need a joint added: those the body's joints do not move it in.

    A direction counts as moved in when it lies in the span of the joints' axes (hinges and a ball
    for rotations, slides for translations; a free joint moves in all), so a joint off the
    element's axes still takes its share and the body never gets more than six dofs.
    """
    spans = {"r": [], "t": []}
    for _, j in body_joints(rigid, body_name):
        kind = int(rigid.jnt_type[j])
        if kind == FREE:
            return ()
        if kind == BALL:
            spans["r"] += list(np.eye(3))
        else:
            spans["r" if kind == HINGE else "t"].append(R_BE.T @ rigid.jnt_axis[j])
    added = []
    for d in directions:
        span = spans["r" if d.startswith("r") else "t"]
        axis = np.eye(3)["xyz".index(d[-1])]
        if _rank([*span, axis]) > _rank(span):
            span.append(axis)
            added.append(d)
    return tuple(added)


def _rank(vectors) -> int:
    return int(np.linalg.matrix_rank(np.array(vectors), tol=1e-6)) if len(vectors) else 0


def stops_from_ranges(rigid, joints, R_BE) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(lower, upper, notes)``: the stops (element coordinates) that the joints' ranges give.

    ``joints``: ``(name, id)`` in the rigid model; ``R_BE``: the element frame's axes in the
    body's frame. See :mod:`mjflex.mjcf.joints` for the mapping.
    """
    lower, upper, notes = np.full(6, -np.inf), np.full(6, np.inf), []
    for name, j in joints:
        kind, label = int(rigid.jnt_type[j]), name or f"joint #{j}"
        if not rigid.jnt_limited[j]:
            continue
        lo, hi = (float(v) for v in rigid.jnt_range[j])
        if kind == BALL:
            hi = min(hi, math.pi)  # a rotation-vector component never leaves [-pi, pi]
            lower[:3], upper[:3] = np.maximum(lower[:3], -hi), np.minimum(upper[:3], hi)
            notes.append(f"ball joint {label}'s cone range {math.degrees(hi):.4g} deg became stops of +-"
                         f"{math.degrees(hi):.4g} deg on rx, ry, rz (the circumscribed box: exact along each element "
                         "axis, up to sqrt(3) times the angle along a diagonal)")  # fmt: skip
            continue
        if kind not in (HINGE, SLIDE):
            continue
        axis = R_BE.T @ rigid.jnt_axis[j]
        k = int(np.argmax(np.abs(axis)))
        if abs(axis[k]) < 1 - 1e-6:
            notes.append(f"the range of {KIND[kind]} {label} was not carried: its axis {np.round(axis, 4).tolist()} "
                         "(element frame) is not along an element axis; give stops yourself or align the element "
                         "frame with the joint")  # fmt: skip
            continue
        ref = float(rigid.qpos0[rigid.jnt_qposadr[j]])
        bounds = sorted(np.sign(axis[k]) * (v - ref) for v in (lo, hi))
        if kind == HINGE and max(abs(b) for b in bounds) > math.pi:
            notes.append(f"hinge {label}: the side of its range beyond pi from its rest ({np.round(bounds, 4)} rad) "
                         "was not carried: a rotation-vector component never leaves [-pi, pi]")  # fmt: skip
            bounds = [b if abs(b) <= math.pi else math.copysign(math.inf, b) for b in bounds]
        c = k if kind == HINGE else 3 + k
        lower[c], upper[c] = max(lower[c], bounds[0]), min(upper[c], bounds[1])
    return lower, upper, notes


def axis_mismatch(rigid, element, replaced, R_BE, K, directions, stacklevel=2) -> str | None:
    """Warn (:class:`mjflex.LikelyMistakeWarning`) when ``K`` is not softest about the one replaced hinge's axis.

    Checked where the replaced joints are one hinge (with or without slides; ``K``'s rotations in ``directions``),
    or one slide and no hinge (``K``'s translations): the stiffness about (along) the joint's axis, ``a^T K a``,
    more than ``SOFTEST_RATIO`` times the smallest eigenvalue of that block is likely a frame mistake (a hinge
    mapped onto a notch hinge's torsion axis is 3.7 times too stiff). Returns the message, or None.
    """
    kinds = [int(rigid.jnt_type[j]) for _, j in replaced]
    one = kinds.count(HINGE) == 1 or (HINGE not in kinds and kinds.count(SLIDE) == 1)
    if BALL in kinds or FREE in kinds or not one:
        return None
    kind = HINGE if HINGE in kinds else SLIDE
    name, j = replaced[kinds.index(kind)]
    block = [i for i in ((0, 1, 2) if kind == HINGE else (3, 4, 5)) if DIRECTIONS[i] in directions]
    axis = (R_BE.T @ rigid.jnt_axis[j])[[i % 3 for i in block]]
    Kb = 0.5 * (K[np.ix_(block, block)] + K[np.ix_(block, block)].T)
    if len(block) < 2 or abs(np.linalg.norm(axis) - 1) > 1e-6:
        return None
    values, vectors = np.linalg.eigh(Kb)
    about = float(axis @ Kb @ axis)
    if not values[0] > 0 or about <= SOFTEST_RATIO * values[0]:
        return None
    soft = vectors[:, 0] * np.sign(vectors[np.argmax(np.abs(vectors[:, 0])), 0])
    unit, what, how = ("N m/rad", "rotation", "about") if kind == HINGE else ("N/m", "translation", "along")
    labels = [DIRECTIONS[i] for i in block]
    message = (
        f"flexure {element!r} replaces {KIND[kind]} {name!r}, whose axis is the element's "
        f"{_axis_label(axis, labels)}, but K there is {about:.4g} {unit}, {about / values[0]:.3g} times K's softest "
        f"{what} ({values[0]:.4g} {unit}, {how} {_axis_label(soft, labels)}): the joint's motion meets a stiffer "
        "element than its compliant direction. The element frame's z axis is a replaced hinge's (or lone slide's) "
        "axis, as mjflex.geometry's hinges turn about z: give the compliant stiffness on "
        f"{'rz' if kind == HINGE else 'z'} (or the frame you mean with site= or pos=/quat=), or silence "
        "mjflex.LikelyMistakeWarning to keep it"
    )
    warn_likely_mistake(message, stacklevel=stacklevel + 1)
    return message


def _axis_label(v, labels) -> str:
    k = int(np.argmax(np.abs(v)))
    if abs(abs(v[k]) - 1) < 1e-6:
        return ("-" if v[k] < 0 else "") + labels[k]
    return "axis " + " ".join(f"{x:+.3f}{label}" for x, label in zip(v, labels, strict=True))


def rest_from_springs(rigid, body_name, replaced, R_BE, p_BE) -> tuple[np.ndarray, np.ndarray] | None:
    """The element's rest pose ``(pos, quat)`` (frame b in frame a) where the replaced joints' springs rest, or None.

    A replaced joint with a spring (stiffness > 0) whose ``springref`` is not its ``ref`` held the
    body preloaded toward ``springref``; the element keeps that preload when its energy is zero
    with the replaced joints at their ``springref`` (the other joints, added or kept, at their
    rest). ``R_BE``, ``p_BE``: the element frame in the body's frame. None when no replaced joint
    has a spring away from its ``ref``.
    """
    qpos = rigid.qpos0.copy()
    moved = False
    for _, j in replaced:
        adr = slice(rigid.jnt_qposadr[j], rigid.jnt_qposadr[j] + QPOS[int(rigid.jnt_type[j])])
        if rigid.jnt_stiffness[j] > 0 and not np.array_equal(rigid.qpos_spring[adr], rigid.qpos0[adr]):
            qpos[adr], moved = rigid.qpos_spring[adr], True
    if not moved:
        return None
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body_name)
    poses = []
    for q in (rigid.qpos0, qpos):
        data = mujoco.MjData(rigid)
        data.qpos[:] = q
        mujoco.mj_kinematics(rigid, data)
        R_WB = data.xmat[ib].reshape(3, 3)
        poses.append((R_WB @ R_BE, data.xpos[ib] + R_WB @ p_BE))  # frame b; at qpos0 it is frame a too
    (R_Wa, p_Wa), (R_Wb, p_Wb) = poses
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (R_Wa.T @ R_Wb).ravel())
    return R_Wa.T @ (p_Wb - p_Wa), quat
