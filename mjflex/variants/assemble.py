"""Assemble a joint variant: nest the bodies, close the loops, compile, map states and keyframes.

Shared by :func:`mjflex.reduce` and the native builders of :mod:`mjflex.variants.alternatives`. The caller
gives the links (elements as joints or rigid connections), what to do with every element
that stays an mjflex element, and how loops are closed; :func:`assemble` returns the
:class:`~mjflex.variants.variant.Variant`.
"""

import mujoco
import numpy as np

from ..mjcf.spec import compile_spec
from .tree import TreeXml, free_world_bodies, merged_body_map, numbers, spanning_forest
from .variant import PoseFit, Variant, body_names

#: Loop closures that should act as rigid: as stiff as the time step allows (MuJoCo's refsafe raises
#: the time constant to 2 h at run time) and with an impedance close to 1.
HARD_SOLREF = (1e-9, 1.0)
HARD_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


def hinge_closure(tree, link, joint, arm):
    """Two ``connect`` constraints on the hinge axis (at the axis point and ``arm`` m along it)."""
    R_WA, p_WA = tree.pose(link.body_a)
    for k, point in enumerate((joint.point, joint.point + arm * joint.axis)):
        tree.add("equality", "connect", name=f"{link.element}:loop{k}", body1=link.body_a, body2=link.body_b,
                 anchor=numbers(R_WA.T @ (point - p_WA)), solref=numbers(HARD_SOLREF),
                 solimp=numbers(HARD_SOLIMP))  # fmt: skip


def rigid_closure(tree, link):
    """A hard weld between the element's two sites (its record is dropped)."""
    a, b = tree.drop_element(link.element, link.sites)
    tree.add("equality", "weld", name=f"{link.element}:loop", site1=a, site2=b, solref=numbers(HARD_SOLREF),
             solimp=numbers(HARD_SOLIMP))  # fmt: skip


def _by_name(source_model, model, kind, count):
    """Index in ``model`` of each object of ``kind`` of ``source_model`` with the same name (or the same index when
    both have the same unnamed layout); -1 where it is gone."""
    src = [mujoco.mj_id2name(source_model, kind, i) for i in range(count(source_model))]
    dst = {mujoco.mj_id2name(model, kind, i): i for i in range(count(model))}
    if count(source_model) == count(model) and not any(src):
        return list(range(count(model)))
    return [dst.get(n, -1) if n else -1 for n in src]


def keyframes_converted(source_model, spec, model, state_from):
    """Add the source's keyframes to ``spec``: the state through ``state_from``; controls, activations and mocap poses
    by name (the actuators and mocap bodies a variant keeps); returns the recompiled model."""
    if source_model.nkey == 0:
        return model
    acts = _by_name(source_model, model, mujoco.mjtObj.mjOBJ_ACTUATOR, lambda m: m.nu)
    mocap = {}
    for b in range(source_model.nbody):
        if source_model.body_mocapid[b] >= 0:
            name = mujoco.mj_id2name(source_model, mujoco.mjtObj.mjOBJ_BODY, b)
            vb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) if name else -1
            if vb >= 0 and model.body_mocapid[vb] >= 0:
                mocap[int(source_model.body_mocapid[b])] = int(model.body_mocapid[vb])
    data = mujoco.MjData(source_model)
    for k in range(source_model.nkey):
        mujoco.mj_resetDataKeyframe(source_model, data, k)
        mujoco.mj_forward(source_model, data)
        qpos, qvel = state_from(source_model, data)
        name = mujoco.mj_id2name(source_model, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}"
        ctrl, act = np.zeros(model.nu), np.zeros(model.na)
        for a, va in enumerate(acts):
            if va >= 0:
                ctrl[va] = source_model.key_ctrl[k, a]
                if source_model.actuator_actnum[a] and model.actuator_actnum[va] == source_model.actuator_actnum[a]:
                    n, src, dst = model.actuator_actnum[va], source_model.actuator_actadr[a], model.actuator_actadr[va]
                    act[dst : dst + n] = source_model.key_act[k, src : src + n]
        mpos, mquat = np.zeros((model.nmocap, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (model.nmocap, 1))
        for src, dst in mocap.items():
            mpos[dst], mquat[dst] = (
                source_model.key_mpos[k, 3 * src : 3 * src + 3],
                source_model.key_mquat[k, 4 * src : 4 * src + 4],
            )
        extra = {"ctrl": ctrl} if model.nu else {}
        if model.na:
            extra["act"] = act
        if model.nmocap:
            extra.update(mpos=mpos.ravel(), mquat=mquat.ravel())
        spec.add_key(name=name, qpos=qpos, qvel=qvel, time=float(source_model.key_time[k]), **extra)
    return compile_spec(spec, why=None)


def assemble(
    source_spec,
    source_model,
    links,
    *,
    closer,
    name,
    report,
    details,
    pre=None,
    post=None,
    plane=None,
    fewest_joints=False,
    attached=(),
    inplace=None,
):
    """Build the variant.

    Parameters
    ----------
    source_spec, source_model
        The source (compiled spec and its model).
    links : list of Link
        Elements that become joints (or rigid connections); every other element stays.
    closer : callable
        ``closer(tree, link) -> str``: closes the loop that ``link`` would close (adding
        constraints, rewriting or dropping its record) and returns a report line.
    name, report, details
        For the :class:`Variant`; ``report`` is a list of lines, extended here.
    pre : callable, optional
        ``pre(tree)``: edits of the file before it is compiled (e.g. records of kept elements).
    plane : ndarray (3,), optional
        Normal of a planar scene: every free body that is not nested under another one moves
        on planar joints instead of its free joint.
    post : callable, optional
        ``post(tree, model) -> list of str``: last edits that need the compiled tree (e.g.
        tendons over the loops' joints); the file is compiled again afterwards.
    fewest_joints : bool
        Trees of the fewest joints (see :func:`~mjflex.variants.tree.spanning_forest`); default: of
        the most, leaving the rigid and one-joint links to close loops.
    attached : set of str
        Bodies of the source's own kinematic trees (they hang from the world already).
    inplace : callable, optional
        ``inplace(tree) -> list of str``: edits of elements on the bodies' own joints
        (:mod:`mjflex.variants.reduce_edges`), before the loops are closed; returns report lines.
    """
    tree = TreeXml(source_spec, source_model)
    masses = {n: float(source_model.body_mass[i]) for i, n in enumerate(body_names(source_model)) if n}
    edges, closers, roots = spanning_forest(links, masses, fewest_joints=fewest_joints, attached=attached)
    inplace_lines = inplace(tree) if inplace is not None else []
    for parent, child, link in edges:
        tree.nest(parent, child, link.joints, link.element)
        if link.info.get("record") is None:
            tree.drop_element(link.element, link.sites)
        else:  # the element stays, in fewer directions (its text record as given)
            tree.rewrite_element(link.element, link.info["record"])
    if plane is not None:
        children = {child for _, child, _ in edges}
        for body in sorted(free_world_bodies(source_model) - children):
            tree.planar_root(body, plane)
    loop_lines = [closer(tree, link) for link in closers]
    if pre is not None:
        pre(tree)
    spec, model = tree.compile(source_spec)
    if post is not None:
        loop_lines += post(tree, model)
        spec, model = tree.compile(source_spec)
    body_map = merged_body_map(model, source_model)
    state_from = PoseFit(model, body_map)
    model = keyframes_converted(source_model, spec, model, state_from)
    state_from = PoseFit(model, body_map)
    lines = list(report)
    if links:
        lines.append(
            f"kinematic trees rooted at {', '.join(r for r in roots)}; {len(edges)} elements became tree "
            f"joints or rigid links, {len(closers)} close loops; nv {source_model.nv} -> {model.nv}"
        )
    else:
        lines.append(f"nv {source_model.nv} -> {model.nv}")
    lines += inplace_lines
    lines += [line for line in loop_lines if line]
    details = dict(details)
    details.update({
        "roots": roots, "tree": [[p, c, link.element] for p, c, link in edges],
        "loop_closers": [link.element for link in closers], "nv_source": int(source_model.nv), "nv": int(model.nv),
        "nbody": int(model.nbody), "neq": int(model.neq),
    })  # fmt: skip
    return Variant(name, model, "\n".join(lines), body_map, state_from, details, spec)
