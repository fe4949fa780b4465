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
  the joint's own: the energy is then exactly ``1/2 k q^2`` at any angle), or else **the element in
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
    springs: dict  # kept joint id -> (stiffness, damping)
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
    if soft and spans and _spring_exact(model, rec, d, edge, kept, soft):
        for j in kept:
            i = int(np.argmax(np.abs(edge.columns[:, _joint_dofs(model, edge, j)[0]])))
            springs[j] = (float(d.k[i]), float(d.b[i]) if keep_damping else 0.0)
        what = "MuJoCo's joint springs (exact: " + ", ".join(f"{name(j)} {springs[j][0]:.4g}" for j in kept) + ")"
    elif soft:
        record = restricted_record(rec, d, soft, keep_damping)
        what = f"the element in {len(soft)} of 6 directions ({labels})"
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
            k, b = result.springs[j]
            el.set("stiffness", numbers(k))
            el.set("damping", numbers(b + float(model.dof_damping[model.jnt_dofadr[j]])))
            el.set(
                "springref", numbers(model.qpos0[model.jnt_qposadr[j]])
            )  # the element rests where the joint is at qpos0
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


__all__ = ["Edge", "EdgeResult", "edge_of", "edge_result", "joint_users", "rejoint", "restricted_record"]
