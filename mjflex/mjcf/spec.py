"""Helpers for a ``mujoco.MjSpec`` that the builders share: compiling it, poses at ``qpos0``, finding bodies and sites.

* :func:`compile_spec` compiles a spec while a Python ``mjcb_passive`` is installed (MuJoCo
  cannot, :func:`python_callback_lifted`), and words a failure for the caller;
* :func:`reference_body_poses`, :func:`site_pose`: world poses in the reference configuration;
* :func:`find_body`, :func:`find_site`: look-ups that name close matches;
* quaternions as MuJoCo normalizes and converts them (:func:`unit_quaternion`,
  :func:`rotation_from_quaternion`, :func:`quaternion_from_rotation`);
* :func:`exclude_contacts`, :func:`keep_joined_trees_awake`: the contact exclusion and the
  sleep policy an element's bodies need.

Sleeping: MuJoCo ignores forces on sleeping trees, and a plugin cannot change the model's
sleep policies at run time, so :func:`keep_joined_trees_awake` writes ``sleep="never"`` on the
root bodies of the trees that an element joins to another tree or to a mocap body (what
:class:`mjflex.Flexures` does in the compiled model for text records). :func:`mjflex.add_flexure`
and :func:`mjflex.convert_model` write it for every plugin element, whether the spec enables
sleeping or not: a flag that is switched on later (in the viewer's physics panel, or
``model.opt.enableflags``) then finds the trees awake.
"""

import contextlib
import ctypes
import warnings

import mujoco
import numpy as np

from ..core import validation
from . import naming


def unit_quaternion(quat, name):
    q = validation.as_array(quat, name, (4,))
    norm = np.linalg.norm(q)
    if norm < 1e-12:
        raise ValueError(f"{name} = {q.tolist()} is not a rotation (zero norm); use (1, 0, 0, 0) for no rotation")
    return q / norm  # MuJoCo normalizes quaternions the same way


def rotation_from_quaternion(q):
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q)
    return R.reshape(3, 3)


def quaternion_from_rotation(R):
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).ravel())
    return q


def find_body(spec, body, role):
    if isinstance(body, mujoco.MjsBody):
        return body
    if not isinstance(body, str):
        raise TypeError(
            f"{role} must be a body name (str; 'world' grounds) or a mujoco.MjsBody of the spec; got "
            f"{validation.shorten(body)} ({type(body).__name__})"
        )
    found = spec.worldbody if body == "world" else spec.body(body)
    if found is None:
        raise ValueError(f"{role} {body!r} is not a body of the spec ('world' grounds)"
                         + naming.spec_hint(spec, body, "body"))  # fmt: skip
    return found


@contextlib.contextmanager
def python_callback_lifted():
    """A Python ``mjcb_passive`` taken off for the time of the block (MuJoCo cannot compile while one is installed).

    mjflex's own callback is native and stays.
    """
    previous = mujoco.get_mjcb_passive()
    python_callback = previous is not None and not isinstance(previous, ctypes._CFuncPtr)
    if python_callback:
        mujoco.set_mjcb_passive(None)
    try:
        yield
    finally:
        if python_callback:
            mujoco.set_mjcb_passive(previous)


def compile_spec(spec, why: str | None = "place flexures in world coordinates") -> mujoco.MjModel:
    """``spec.compile()``, also while a Python passive callback is installed (MuJoCo cannot compile then).

    ``why``: what the spec had to compile for; a failure raises ValueError saying so (with a hint
    when MuJoCo's error is about a body's mass or inertia, or an actuator's length range).
    ``why=None``: MuJoCo's own error passes through unchanged (the variants, which compile models
    they built themselves).
    """
    try:
        with python_callback_lifted():
            return spec.compile()
    except ValueError as exc:
        if why is None:
            raise
        text = str(exc)
        # the only case where adding geoms or inertias first helps: MuJoCo's "mass and inertia of moving bodies
        # must be larger than mjMINVAL", a zero inertia, ...
        about_inertia = "inertia" in text.lower() or "mass" in text.lower()
        hint = "; add the bodies' geoms or inertias before the flexures" if about_inertia else ""
        if "lengthrange computation did not converge" in text.lower():
            hint = (
                "; elements exert no force in the compiler's length-range simulation: give the actuator its "
                'lengthrange, or keep <compiler><lengthrange useexisting="true"/> (mjflex.make_compliant '
                "then writes the rigid model's ranges)"
            )
        raise ValueError(f"the spec must compile to {why} ({text.strip()}){hint}") from None


def reference_body_poses(spec) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """World positions ``(nbody, 3)``, rotation matrices ``(nbody, 3, 3)`` and names of the
    bodies of ``spec`` in its reference configuration (``qpos0``).

    Compiling a spec takes time: pass the result as ``poses=`` to :func:`add_flexure` when adding
    many elements to one spec.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model; it must compile.

    Returns
    -------
    xpos : ndarray, shape (nbody, 3)
        Origins of the body frames in world coordinates [m] (body 0 is the world).
    xmat : ndarray, shape (nbody, 3, 3)
        Orientations of the body frames, ``R_WB`` (columns: the body's axes in world coordinates).
    names : list of str
        The bodies' names (``""`` for unnamed bodies).

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="B" pos="0 0 -0.1"><freejoint/><geom size="0.01"/></body></worldbody>'
    ...     "</mujoco>"
    ... )
    >>> xpos, xmat, names = mjflex.reference_body_poses(spec)
    >>> names, xpos[1].tolist(), xmat.shape
    (['world', 'B'], [0.0, 0.0, -0.1], (2, 3, 3))
    """
    model = compile_spec(spec)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or "" for i in range(model.nbody)]
    return data.xpos.copy(), data.xmat.reshape(-1, 3, 3).copy(), names


def site_pose(spec, site) -> tuple[np.ndarray, np.ndarray]:
    """World position ``(3,)`` and rotation matrix ``(3, 3)`` of a site of ``spec`` at ``qpos0``.

    ``site``: its name or the ``mujoco.MjsSite``. Raises ValueError naming close matches.
    """
    name = find_site(spec, site).name
    model = compile_spec(spec, f"find site {name!r} in world coordinates")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    return data.site_xpos[i].copy(), data.site_xmat[i].reshape(3, 3).copy()


def find_site(spec, site):
    if not isinstance(site, str):
        if not isinstance(site, mujoco.MjsSite) or not site.name:
            raise ValueError(f"site must be the name of a site of the spec (or a named MjsSite); got {site!r}")
        site = site.name
    found = spec.site(site)
    if found is None:
        raise ValueError(f"site {site!r} is not a site of the spec"
                         + naming.spec_hint(spec, site, "site"))  # fmt: skip
    return found


def exclude_contacts(spec, body_a, body_b) -> None:
    """Add ``<exclude body1 body2/>`` for two named bodies of ``spec`` unless the pair is excluded already."""
    pair = {body_a.name, body_b.name}
    if not any({e.bodyname1, e.bodyname2} == pair for e in spec.excludes):
        spec.add_exclude(bodyname1=body_a.name, bodyname2=body_b.name)


_NEVER = mujoco.mjtSleepPolicy.mjSLEEP_NEVER


_CHOSEN = (mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED, mujoco.mjtSleepPolicy.mjSLEEP_INIT)


def _tree_root(spec, body):
    """The root body of the kinematic tree that moves ``body`` (the topmost body with joints above it), or None."""
    root = None
    while body is not None and body is not spec.worldbody and body.name != "world":
        if len(body.joints) > 0:
            root = body
        body = body.parent
    return root


def keep_joined_trees_awake(spec, elements) -> list[str]:
    """Write ``sleep="never"`` on the root body of every tree an element joins to another tree or a mocap body.

    ``elements``: ``(name, site a, site b)`` of the elements. A root whose sleep policy the model
    chose explicitly (``allowed`` or ``init``) is kept, with a warning naming the element (the
    element's force is lost while its tree sleeps). Returns the names of the bodies set.
    """
    changed, kept = [], []
    for name, site_a, site_b in elements:
        bodies = [spec.site(s).parent if spec.site(s) is not None else None for s in (site_a, site_b)]
        if any(b is None for b in bodies):
            continue
        roots = [_tree_root(spec, b) for b in bodies]
        if roots[0] is roots[1] and roots[0] is not None:
            continue  # one tree: the force is internal to it
        mocap = any(getattr(b, "mocap", False) for b in bodies)
        if all(r is None for r in roots) or (None in roots and not mocap):
            continue  # grounded to a static body: the tree may sleep in balance
        for root in roots:
            if root is None:
                continue
            if root.sleep in _CHOSEN:
                kept.append((name, root.name or "(unnamed)", root.sleep))
            elif root.sleep != _NEVER:
                root.sleep = _NEVER
                changed.append(root.name)
    if kept:
        name, body, policy = kept[0]
        warnings.warn(
            f"mjflex: flexure {name!r} joins the tree of body {body!r}, whose sleep policy "
            f"{mujoco.mjtSleepPolicy(policy).name} lets it sleep (and {len(kept) - 1} more): MuJoCo ignores forces on "
            'sleeping trees, so the element\'s force is lost while it sleeps. Set sleep="never" (or "auto") on the '
            "tree's root body, or keep sleeping disabled.",
            UserWarning,
            stacklevel=3,
        )
    return changed


def check_spec(spec):
    if not isinstance(spec, mujoco.MjSpec):
        raise TypeError(f"spec must be a mujoco.MjSpec; got {type(spec).__name__}")
