"""Assemble a joint variant: nest the bodies, close the loops, compile, map states and keyframes.

Shared by :func:`mjflex.reduce` and the native builders of :mod:`mjflex.variants.alternatives`. The caller
gives the links (elements as joints or rigid connections), what to do with every element
that stays an mjflex element, and how loops are closed; :func:`assemble` returns the
:class:`~mjflex.variants.variant.Variant`.
"""

import mujoco
import numpy as np

from ..mjcf.spec import compile_spec
from .tree import TreeXml, free_world_bodies, merged_body_map, spanning_forest
from .variant import PoseFit, Variant, body_names

#: Loop closures that should act as rigid: as stiff as the time step allows (MuJoCo's refsafe raises
#: the time constant to 2 h at run time) and with an impedance close to 1.
HARD_SOLREF = (1e-9, 1.0)
HARD_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


def _fmt(v):
    return " ".join(f"{float(x):.17g}" for x in np.atleast_1d(v))


def hinge_closure(tree, link, joint, arm):
    """Two ``connect`` constraints on the hinge axis (at the axis point and ``arm`` m along it)."""
    R_WA, p_WA = tree.pose(link.body_a)
    for k, point in enumerate((joint.point, joint.point + arm * joint.axis)):
        tree.add("equality", "connect", name=f"{link.element}:loop{k}", body1=link.body_a, body2=link.body_b,
                 anchor=_fmt(R_WA.T @ (point - p_WA)), solref=_fmt(HARD_SOLREF), solimp=_fmt(HARD_SOLIMP))  # fmt: skip


def rigid_closure(tree, link):
    """A hard weld between the element's two sites (its record is dropped)."""
    a, b = tree.drop_element(link.element, link.sites)
    tree.add("equality", "weld", name=f"{link.element}:loop", site1=a, site2=b, solref=_fmt(HARD_SOLREF),
             solimp=_fmt(HARD_SOLIMP))  # fmt: skip


def keyframes_converted(source_model, spec, model, state_from):
    """Add the source's keyframes to ``spec`` through ``state_from``; returns the recompiled model."""
    if source_model.nkey == 0:
        return model
    data = mujoco.MjData(source_model)
    for k in range(source_model.nkey):
        mujoco.mj_resetDataKeyframe(source_model, data, k)
        mujoco.mj_forward(source_model, data)
        qpos, qvel = state_from(source_model, data)
        name = mujoco.mj_id2name(source_model, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}"
        spec.add_key(name=name, qpos=qpos, qvel=qvel, time=float(source_model.key_time[k]))
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
    """
    tree = TreeXml(source_spec, source_model)
    masses = {n: float(source_model.body_mass[i]) for i, n in enumerate(body_names(source_model)) if n}
    edges, closers, roots = spanning_forest(links, masses, fewest_joints=fewest_joints)
    for parent, child, link in edges:
        tree.nest(parent, child, link.joints, link.element)
        tree.drop_element(link.element, link.sites)
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
    lines.append(f"kinematic trees rooted at {', '.join(r for r in roots)}; {len(edges)} elements became tree "
                 f"joints or rigid links, {len(closers)} close loops; nv {source_model.nv} -> {model.nv}")  # fmt: skip
    lines += [line for line in loop_lines if line]
    details = dict(details)
    details.update({
        "roots": roots, "tree": [[p, c, link.element] for p, c, link in edges],
        "loop_closers": [link.element for link in closers], "nv_source": int(source_model.nv), "nv": int(model.nv),
        "nbody": int(model.nbody), "neq": int(model.neq),
    })  # fmt: skip
    return Variant(name, model, "\n".join(lines), body_map, state_from, details, spec)
