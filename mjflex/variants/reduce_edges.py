"""Elements on a body's own joints: reduced in place, keeping the joints (and their names) that the reduction needs.

After :func:`mjflex.make_compliant` (``replace_joints=True`` or not) an element acts between a body and
its parent, and the body's joints are the element's coordinates: the body moves in every direction
of the element through them. Such an element is an **edge** of the model's own kinematic tree; a
reduction rewrites the body's joints instead of re-rooting it:

* the joints whose motion lies in the directions left compliant are **kept as they are**: name,
  axis, anchor, reference, armature, range; so an actuator, a sensor, a tendon, an equality or a
  controller written for the source still finds them. The others (the directions held rigid) go:
  the body is locked where they were at ``qpos0``, so nothing moves. If the kept joints do not
  move along exactly the compliant directions, the body gets new joints ``<element>:<direction>``
  instead (the report says so, and which armature went).
* a direction moved by a joint that an actuator, a tendon or an equality names is **needed**: it is
  never held rigid (a reduction must not take a driven or coupled joint away);
* what the element becomes: nothing (all directions rigid: the body is welded to its parent), or
  **MuJoCo's own springs** where they are exact (one kept hinge whose angle is the element's
  rotation about a principal axis through its centre of stiffness, or slides alone along
  decoupled principal translations, twist method, no polynomial terms or stops, and no spring of
  the joint's own: the energy is then exactly ``1/2 k q^2`` at any angle; a rest pose that the joints
  reach alone becomes their ``springref``, :func:`spring_refs`), or else **the element in
  fewer directions**: its stiffness and damping restricted to the compliant ones (the stiff ones
  no longer ring at deflected poses), its stops kept with the stiffness they had.
* sensors that read a joint that goes (``jointpos``, ...) are removed and reported by name.

``edge_of`` decides whether an element is such an edge, ``joint_users`` finds what names a
joint, ``edge_result`` what an edge becomes, and ``rejoint`` edits the model file.
"""

import dataclasses
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..core.rest import rest_pose
from ..core.transforms import twist_from_transform
from ..mjcf import schema
from .tree import WORLD, numbers

_J = mujoco.mjtJoint
#: Relative size below which a joint's motion along a direction counts as none.
ALIGN_TOL = 1e-9


@dataclass
class Edge:
    """An element on the joints of a body relative to its parent (see the module docstring).

    ``columns`` ``(6, ndof)``: principal velocity of the element per unit velocity of each of the
    child's dofs; ``free`` ``(6,)``: the directions those joints can move at all (the others are
    rigid already); ``needed``: direction index -> the names (``"actuator a1"``) that need it.
    """

    child: str
    parent: str
    joints: list  # joint ids of the child, in order
    names: list  # their names ("" when unnamed)
    dofs: np.ndarray
    columns: np.ndarray
    free: np.ndarray
    needed: dict = field(default_factory=dict)


@dataclass
class EdgeResult:
    """What an edge becomes: the joints kept (ids), new joints, springs per kept joint, or a restricted record."""

    kept: list
    removed: list
    new: list  # Joint specs (tree.Joint) when the source joints do not fit
    springs: dict  # kept joint id -> (stiffness, damping, springref)
    record: object  # FlexureRecord of the element in fewer directions, or None (dropped)
    lines: list


def joint_users(model) -> dict[int, list[str]]:
    """Joint id -> the actuators, tendons and equality constraints that name it (``"actuator a1"``, ...)."""
    users = {}

    def name(kind, i):
        return mujoco.mj_id2name(model, kind, i) or f"#{i}"

    for a in range(model.nu):
        if int(model.actuator_trntype[a]) in (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)):
            users.setdefault(int(model.actuator_trnid[a, 0]), []).append(
                f"actuator {name(mujoco.mjtObj.mjOBJ_ACTUATOR, a)}"
            )
    for t in range(model.ntendon):
        for w in range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t]):
            if int(model.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT):
                users.setdefault(int(model.wrap_objid[w]), []).append(f"tendon {name(mujoco.mjtObj.mjOBJ_TENDON, t)}")
    for q in range(model.neq):
        if int(model.eq_type[q]) == int(mujoco.mjtEq.mjEQ_JOINT):
            for j in (model.eq_obj1id[q], model.eq_obj2id[q]):
                if j >= 0:
                    users.setdefault(int(j), []).append(f"equality {name(mujoco.mjtObj.mjOBJ_EQUALITY, q)}")
    return users


def edge_of(model, d, users, body_names):
    """The :class:`Edge` of element directions ``d`` (:class:`~mjflex.analysis.directions.Directions`), or None.

    An edge: one body is the other's parent, the child has joints and no free joint, and each
    joint moves the element either in directions no other joint moves (aligned with principal
    directions) or the joints together move it in all six.
    """
    for child, parent in ((d.body_b, d.body_a), (d.body_a, d.body_b)):
        if child == 0 or model.body_parentid[child] != parent or model.body_jntnum[child] == 0:
            continue
        joints = list(range(model.body_jntadr[child], model.body_jntadr[child] + model.body_jntnum[child]))
        if any(int(model.jnt_type[j]) == int(_J.mjJNT_FREE) for j in joints):
            return None
        dofs = np.arange(model.body_dofadr[child], model.body_dofadr[child] + model.body_dofnum[child])
        columns = d.J[:, dofs]
        scale = max(float(np.abs(columns).max(initial=0.0)), 1e-300)
        moved = np.abs(columns) > ALIGN_TOL * scale
        if np.linalg.matrix_rank(columns, tol=1e-9 * scale) < 6:  # fewer joints: each must move its own directions
            owner = [set(np.nonzero(moved[:, k])[0]) for k in range(len(dofs))]
            if any(owner[a] & owner[b] for a in range(len(dofs)) for b in range(a)):
                return None
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or "" for j in joints]
        needed = {}
        for k, dof in enumerate(dofs):
            for user in users.get(int(model.dof_jntid[dof]), []):
                for i in np.nonzero(moved[:, k])[0]:
                    needed.setdefault(int(i), []).append(user)
        return Edge(body_names[child] or f"#{child}", body_names[parent] if parent else WORLD, joints, names,
                    dofs, columns, moved.any(axis=1), needed)  # fmt: skip
    return None


def _joint_dofs(model, edge, j):
    start = model.jnt_dofadr[j]
    n = {int(_J.mjJNT_BALL): 3}.get(int(model.jnt_type[j]), 1)
    return [k for k, dof in enumerate(edge.dofs) if start <= dof < start + n]


def _spring_exact(model, rec, d, edge, kept, soft):
    """Whether MuJoCo's springs on the kept joints give the element's energy exactly (module docstring)."""
    if rec.method != "twist" or rec.terms is not None or rec.stops or len(kept) != len(soft):
        return False
    if not (len(soft) == 1 or all(i >= 3 for i in soft)):
        return False
    K = d.K_P[np.ix_(soft, soft)]
    if np.abs(K - np.diag(np.diag(K))).max(initial=0.0) > 1e-12 * np.abs(K).max(initial=1e-300):
        return False
    for j in kept:
        if int(model.jnt_type[j]) not in (int(_J.mjJNT_HINGE), int(_J.mjJNT_SLIDE)) or model.jnt_stiffness[j] != 0.0:
            return False
        col = edge.columns[:, _joint_dofs(model, edge, j)[0]]
        i = int(np.argmax(np.abs(col)))
        if i not in soft or abs(abs(col[i]) - 1.0) > ALIGN_TOL or np.abs(np.delete(col, i)).max() > ALIGN_TOL:
            return False
    return True


def _relative_pose(model, data, sites):
    """``(R_ab, p_ab)``: frame b of an element in frame a (its sites) at ``data``'s kinematics."""
    a, b = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name) for name in sites)
    R_Wa, R_Wb = data.site_xmat[a].reshape(3, 3), data.site_xmat[b].reshape(3, 3)
    return R_Wa.T @ R_Wb, R_Wa.T @ (data.site_xpos[b] - data.site_xpos[a])


def rest_coordinates(rec, d) -> np.ndarray:
    """The principal coordinates ``(6,)`` of an element's rest pose, ``T log X_r`` (zeros without one; rad, m)."""
    if rec.rest is None:
        return np.zeros(6)
    p_r, _, R_r = rest_pose(rec.rest, f"rest of flexure {rec.name!r}")
    return d.T @ twist_from_transform(R_r, p_r, check=False)


def preloaded(rec, d, extent) -> list[int]:
    """The principal directions an element's rest pose needs compliant: held rigid where the model compiled, a
    direction would hold the preload forever. A rest pose along one direction (a rotation about a principal axis
    through the centre of stiffness, a translation) or along translations only (they commute) needs those; any
    other (a rotation off a hinge's axis: reaching it takes every rotation, to second order) needs all six, so the
    element stays whole. Components below 1e-9 rad, or 1e-9 of the model's extent, count as none."""
    delta = rest_coordinates(rec, d)
    size = np.r_[np.ones(3), np.full(3, max(float(extent), 1e-3))]
    moved = [int(i) for i in np.nonzero(np.abs(delta) > 1e-9 * size)[0]]
    return moved if len(moved) <= 1 or min(moved) >= 3 else list(range(6))


def spring_refs(model, rec, d, edge, kept):
    """The ``springref`` of each kept joint (joint id -> qpos value) at which MuJoCo's springs rest where the
    element does, or None when its rest pose is not one the kept joints reach (the element then stays).

    Without a rest pose: ``qpos0`` (the element rests at the compiled pose). With one (``X_r``, the pose of b in a
    at rest, :mod:`mjflex.core.rest`): its principal coordinates ``T log X_r`` give each joint's deflection (a
    rotation about the hinge's axis through the centre of stiffness, translations along the slides), and the
    joints set there must put frame b where the element rests, ``X_r X_res`` (``X_res``: the sites' rounding,
    measured at ``qpos0``), to 1e-9: the exact case, where the energy is ``1/2 k (q - springref)^2``.
    """
    refs = {j: float(model.qpos0[model.jnt_qposadr[j]]) for j in kept}
    if rec.rest is None:
        return refs
    p_r, _, R_r = rest_pose(rec.rest, f"rest of flexure {rec.name!r}")
    delta = rest_coordinates(rec, d)
    for j in kept:
        col = edge.columns[:, _joint_dofs(model, edge, j)[0]]
        i = int(np.argmax(np.abs(col)))
        refs[j] += float(delta[i] / col[i])
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    R_res, p_res = _relative_pose(model, data, d.sites)
    for j, ref in refs.items():
        data.qpos[model.jnt_qposadr[j]] = ref
    mujoco.mj_kinematics(model, data)
    R_ab, p_ab = _relative_pose(model, data, d.sites)
    size = max(float(np.linalg.norm(p_r)), float(model.stat.extent), 1e-3)
    exact = np.abs(R_ab - R_r @ R_res).max() <= 1e-9 and np.linalg.norm(p_ab - (p_r + R_r @ p_res)) <= 1e-9 * size
    return refs if exact else None


def restricted_record(rec, d, soft, keep_damping):
    """``rec`` in the principal directions ``soft`` only: K and B restricted, stops kept with their stiffness, the rest
    pose kept."""
    K, B = d.restricted(soft)
    stops = rec.stops
    if stops:
        stops = dataclasses.replace(stops, stiffness=tuple(stops.stiffness_for(rec.K).tolist()))
    B = B if keep_damping and rec.B is not None else None
    return schema.FlexureRecord(rec.name, rec.method, K, B, rec.enabled, True if B is None else rec.viscous,
                                rec.strain_per_radian, rec.source, None, 2, stops=stops, rest=rec.rest)  # fmt: skip


def edge_result(model, rec, d, edge, soft, keep_damping, new_joints):
    """What the edge becomes with the principal directions ``soft`` compliant (:class:`EdgeResult`).

    ``new_joints(soft) -> list of Joint``: the joints (without springs) that replace the body's own when those do
    not move along exactly the compliant directions.
    """
    soft = sorted(soft)
    rigid = [i for i in range(6) if i not in soft]
    scale = max(float(np.abs(edge.columns).max(initial=0.0)), 1e-300)
    fits = [j for j in edge.joints if np.abs(edge.columns[np.ix_(rigid, _joint_dofs(model, edge, j))]).max(initial=0.0)
            <= ALIGN_TOL * scale]  # fmt: skip
    dofs = [k for j in fits for k in _joint_dofs(model, edge, j)]
    spans = not soft or np.linalg.matrix_rank(edge.columns[np.ix_(soft, dofs)], tol=1e-9 * scale) == len(soft)

    def name(j):
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"

    def arm(j):
        return float(model.dof_armature[model.jnt_dofadr[j]])

    labels = ", ".join(d.labels[i] for i in soft) or "none"
    lines = []
    if spans:
        kept, new = fits, []
    else:
        kept, new = [], new_joints(soft)
        lines.append(
            f"{rec.name}: the joints of {edge.child} ({', '.join(name(j) for j in edge.joints)}) do not move "
            f"along exactly its compliant directions ({labels}): replaced by {len(new)} new joints"
        )
    removed = [j for j in edge.joints if j not in kept]
    springs = {}
    record = None
    exact = soft and spans and _spring_exact(model, rec, d, edge, kept, soft)
    refs = spring_refs(model, rec, d, edge, kept) if exact else None
    if refs is not None:
        for j in kept:
            i = int(np.argmax(np.abs(edge.columns[:, _joint_dofs(model, edge, j)[0]])))
            springs[j] = (float(d.k[i]), float(d.b[i]) if keep_damping else 0.0, refs[j])
        rest = "; springref " + ", ".join(f"{name(j)} {refs[j]:.6g}" for j in kept) if rec.rest is not None else ""
        what = "MuJoCo's joint springs (exact: " + ", ".join(f"{name(j)} {springs[j][0]:.4g}" for j in kept) + rest
        what += ")"
    elif soft:
        record = restricted_record(rec, d, soft, keep_damping)
        what = f"the element in {len(soft)} of 6 directions ({labels})"
        if exact:  # the springs would be exact but for the preload
            what += ": its rest pose is not a motion of the kept joints alone, which MuJoCo's springref could hold"
    else:
        what = f"nothing: {edge.child} is welded to {edge.parent}"
    kept_text = ", ".join(f"{name(j)} (armature {arm(j):.3g})" for j in kept) or "none"
    lines.insert(0, f"{rec.name}: in place on {edge.child}'s joints: compliant {labels}; joints kept {kept_text}; "
                    f"it becomes {what}")  # fmt: skip
    if removed:
        gone = [f"{name(j)}" + (f" (its armature {arm(j):.3g} dropped)" if arm(j) else "") for j in removed]
        lines.append(f"{rec.name}: joints held rigid and removed: {', '.join(gone)}")
    return EdgeResult(kept, removed, new, springs, record, lines)


def rejoint(tree, model, rec, edge, result, sites):
    """Edit the model file for one edge: remove joints, set springs, write the record or drop it; report lines."""
    body_el = tree.bodies[edge.child]
    xml_joints = [c for c in body_el if c.tag == "joint"]
    if len(xml_joints) != len(edge.joints):
        raise ValueError(f"{rec.name}: body {edge.child!r} has {len(edge.joints)} joints compiled but "
                         f"{len(xml_joints)} written in the model file; cannot rewrite them")  # fmt: skip
    lines = []
    gone = set()
    for el, j in zip(xml_joints, edge.joints, strict=True):
        if j in result.removed:
            body_el.remove(el)
            if el.get("name"):
                gone.add(el.get("name"))
        elif j in result.springs:
            k, b, ref = result.springs[j]
            el.set("stiffness", numbers(k))
            el.set("damping", numbers(b + float(model.dof_damping[model.jnt_dofadr[j]])))
            el.set("springref", numbers(ref))  # where the element rests: qpos0, or its rest pose (spring_refs)
    tree.insert_joints(edge.child, result.new, rec.name)
    for section in tree.root.findall("sensor"):
        for sensor in list(section):
            if sensor.get("joint") in gone:
                section.remove(sensor)
                lines.append(f"{rec.name}: sensor {sensor.get('name') or sensor.tag} removed (it read joint "
                             f"{sensor.get('joint')}, held rigid)")  # fmt: skip
    if result.record is None:
        tree.drop_element(rec.name, sites)
    else:
        tree.rewrite_element(rec.name, result.record.to_text())
    return lines


__all__ = [
    "Edge",
    "EdgeResult",
    "edge_of",
    "edge_result",
    "joint_users",
    "preloaded",
    "rejoint",
    "rest_coordinates",
    "restricted_record",
    "spring_refs",
]
