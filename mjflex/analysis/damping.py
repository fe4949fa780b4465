"""Damping matrices from damping ratios, through a modal analysis of the model.

A user asks for a damping ratio (1 %) and should measure it (a logarithmic decrement). The ratio
of a mode depends on the inertia that moves with it, which a hand estimate gets wrong (a robot
hand's inertia about its wrist is hard to guess), so :func:`damping_from_ratios` takes it from
the linearized model itself: MuJoCo's joint-space inertia and the tangent stiffness at a
configuration (:mod:`mjflex.analysis.linearize`).
"""

import mujoco
import numpy as np
import scipy.linalg

from ..mjcf import schema
from ..mjcf.notices import warn_likely_mistake
from ..runtime.flexures import Flexures
from .directions import element_matrices
from .linearize import (
    STEP,
    Options,
    central_differences,
    check_constraints,
    data_at,
    linearize,
    loads,
    null_space,
    state,
)

#: Names of the six directions of an element, in the order of K's rows (element frame).
DIRECTIONS = ("rx", "ry", "rz", "x", "y", "z")
OTHERS = ("locked", "free")


def checked_ratios(ratios, n, what="damping_ratio", *, strict=False, stacklevel=2) -> np.ndarray:
    """``(n,)`` damping ratios from a number or ``n`` numbers, each finite and > 0; raises ValueError.

    A ratio above 1 (overdamped: legal, but ``10`` is usually meant as 10 %, i.e. ``0.1``) gives a
    :class:`~mjflex.mjcf.notices.LikelyMistakeWarning` naming it, attributed ``stacklevel`` frames
    up, or a ValueError with ``strict``.
    """
    try:
        r = np.asarray(ratios, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number or {n} numbers; got {ratios!r}") from None
    if r.ndim == 0:
        r = np.full(n, float(r))
    if r.shape != (n,):
        raise ValueError(f"{what} must be a number or {n} numbers (one per direction); got shape {r.shape}")
    bad = ~(np.isfinite(r) & (r > 0))
    if bad.any():
        raise ValueError(
            f"{what} = {r.tolist()}: every ratio must be a finite number > 0 (0.01 is 1 % of critical damping); "
            "for no damping leave the ratio out"
        )
    if np.any(r > 1):
        big = r[r > 1]
        message = (
            f"{what} = {r.tolist()}: a ratio above 1 is overdamped ({big.max():.4g} times critical damping). A ratio "
            f"is a fraction of critical damping: {big.max():.4g} % is {big.max() / 100:.4g}. An overdamped element "
            "also needs a much smaller time step (its damping acts explicitly)"
        )
        if strict:
            raise ValueError(message + "; strict=True refuses it")
        warn_likely_mistake(message + "; pass strict=True to refuse such values", stacklevel=stacklevel)
    return r


def _moving_dofs(model, body) -> set:
    """The dofs of ``body`` and of its ancestors: every dof whose motion moves it."""
    out = set()
    while body > 0:
        out.update(range(model.body_dofadr[body], model.body_dofadr[body] + model.body_dofnum[body]))
        body = int(model.body_parentid[body])
    return out


def element_dofs(model, flex, element) -> np.ndarray:
    """Dofs that move one of the element's bodies but not the other: those on the tree path between them."""
    a, b = (int(x) for x in flex.body_ids[flex.index(element)])
    return np.array(sorted(_moving_dofs(model, a) ^ _moving_dofs(model, b)), dtype=int)


def displacement_jacobian(model, flex, element, base, step=STEP) -> np.ndarray:
    """``(6, nv)``: derivative of the element's finite twist ``[tau; t]`` (element frame) along each
    tangent direction of the configuration in ``base`` (:func:`.linearize.central_differences`)."""
    e = flex.index(element)

    def twist(data):
        mujoco.mj_kinematics(model, data)
        return flex.displacements(data)[e]

    return central_differences(model, data_at(model, base), twist, step=step)


def damping_from_ratios(model, element, ratios, *, flex=None, keyframe=None, qpos=None, others="locked",
                        actuator_stiffness=False, gravity=False, constraints="ignore", xfrc_applied=None,
                        qfrc_applied=None, ctrl=None, strict=False, step=STEP) -> np.ndarray:  # fmt: skip
    """Damping matrix ``B`` of an element that gives its modes the requested damping ratios.

    The element's modes come from an undamped modal analysis of the model at a configuration
    (``qpos0``, a keyframe, or ``qpos``), ``K_s phi = omega^2 M_s phi``, where ``M_s`` is
    MuJoCo's joint-space inertia and ``K_s`` the tangent stiffness (every element, MuJoCo's joint
    and tendon springs, and optionally the actuators and gravity; :func:`mjflex.normal_modes`),
    restricted to a set of dofs ``s``:

    * ``others="locked"`` (default): only the dofs on the kinematic path between the element's
      two bodies move (for :func:`mjflex.make_compliant`, the joints it added); every other joint
      is held at the configuration. The inertia is then that of the whole subtree the element
      carries (a hand with its fingers as they are at the keyframe) about the element frame,
      with the other body fixed: what a rigidly mounted part would show.
    * ``others="free"``: every dof moves, held only by what holds it in the model (elements,
      springs, and the actuators if ``actuator_stiffness``: position servos' ``kp``). For a part
      on a servo-held arm whose joints yield noticeably.

    Equality constraints enter as in :func:`mjflex.normal_modes` (``constraints``): ignored,
    as springs, or projected (``"project"``: the modes live in the null space of the
    constraints' Jacobian restricted to the moving dofs, ``N^T K N psi = omega^2 N^T M N psi``,
    ``phi = N psi``): for a spine whose levels equalities tie together, neither ``"locked"`` nor
    ``"free"`` alone describes the motion; ``others="free", constraints="project"`` does.

    The element's modes are the ``n`` modes (``n``: the number of independent element
    directions the dofs can move) that store the largest share of their strain energy in the
    element. With ``psi_k`` the element displacement of mass-normalized mode ``k`` (``J phi_k``,
    ``J`` the Jacobian of the element's finite twist), ``Psi = [psi_1 ... psi_n]`` (6 x n) and
    ``Psi^+`` its pseudo-inverse, ``B = Psi^+^T diag(2 zeta_k omega_k) Psi^+``: then
    ``phi_k^T J^T B J phi_l = 2 zeta_k omega_k delta_kl`` on those modes, so each gets exactly
    its ratio and none is coupled to another by the damping. With ``others="locked"`` and
    nothing but this element acting on those dofs the damping is exactly classical; otherwise
    modes outside the element's set keep a small coupling, of order of the ratios.

    Coupled directions: a mode generally moves several element directions (a hand's bending
    couples rotation and translation when its centre of mass is off the element frame). Given one
    ratio, every element mode gets it. Given one ratio per direction, mode ``k`` gets the mean of
    the ratios weighted by the share of the mode's element strain energy in each direction,
    ``w_d = psi_d (K_e psi)_d / psi^T K_e psi`` (negative shares from off-diagonal terms of
    ``K_e`` count as zero): a mode that is pure bending gets the bending ratio, a mixed mode a
    mix.

    Parameters
    ----------
    model : mujoco.MjModel
    element : str
        The element's name.
    ratios : float or array_like, shape (6,) or (3,)
        Damping ratios (fractions of critical, > 0): one for every mode, or one per element
        direction ``[rx, ry, rz, x, y, z]`` of the element frame (``[theta_z, x, y]`` for a
        planar element).
    flex : Flexures, optional
        The model's provider (built here if not given).
    keyframe : str or int, optional
        Configuration (and the controls the actuators see) to linearize at; ``qpos`` overrides it.
    qpos : array_like, shape (nq,), optional
        Configuration to linearize at (overrides the keyframe's).
    ctrl : array_like, shape (nu,), optional
        The actuator commands (override the keyframe's; :func:`mjflex.normal_modes`).
    others : {"locked", "free"}
        What the dofs not between the element's bodies do (see above).
    actuator_stiffness, gravity : bool
        Add the actuators' stiffness, gravity's load stiffness (:func:`mjflex.normal_modes`).
    constraints : {"ignore", "spring", "project"}
        How equality constraints enter (see above; :mod:`mjflex.analysis.linearize`).
    xfrc_applied : array_like, shape (nbody, 6), optional
        Dead loads ``[force; torque]`` at the bodies' centres of mass (world axes): their load
        stiffness enters, as in :func:`mjflex.normal_modes`.
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads.
    strict : bool
        Refuse a ratio above 1 (ValueError) instead of warning about it.
    step : float
        Finite-difference step [m or rad].

    Returns
    -------
    B : ndarray, shape (6, 6) or (3, 3)
        Symmetric positive semi-definite damping in the element frame, rows
        ``[rotation; translation]`` (N m s/rad, N s/m), the layout of the element's ``K``.

    Examples
    --------
    A tool on an arm's flange, made compliant; 1 % of critical damping in each of its six modes, the shoulder held:

    >>> import mujoco
    >>> import numpy as np
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="link" pos="0 0 0.5"><joint name="shoulder" axis="0 1 0"/>'
    ...     '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
    ...     '<site name="flange" pos="0.3 0 0" quat="0.7071068 0 0.7071068 0"/>'
    ...     '<body name="tool" pos="0.3 0 0"><geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02"/></body>'
    ...     "</body></worldbody></mujoco>"
    ... )
    >>> _ = mjflex.make_compliant(spec, "tool", K=[50, 50, 30, 1e5, 1e5, 1e5], site="flange")
    >>> model = spec.compile()
    >>> B = mjflex.damping_from_ratios(model, "tool_compliance", 0.01)
    >>> B.shape, bool(np.allclose(B, B.T)), bool(np.all(np.linalg.eigvalsh(B) > -1e-12 * np.abs(B).max()))
    ((6, 6), True, True)

    :func:`mjflex.make_compliant` does this itself when given ``damping_ratio=``.
    """
    if others not in OTHERS:
        raise ValueError(f"others={others!r}: use one of {OTHERS}")
    check_constraints(constraints)
    flex = Flexures(model) if flex is None else flex
    if flex.model is not model:
        raise ValueError("flex must be the Flexures of this model (flex.model is model)")
    record = flex.records[flex.index(element)]
    Ke = element_matrices(record)[0]
    given = checked_ratios(ratios, 3 if record.planar else 6, strict=strict, stacklevel=3)
    r = given
    if record.planar:  # the other directions do not move a planar element: their weights are zero
        r = np.full(6, given.mean())
        r[list(schema.PLANAR_INDEX)] = given
    load = loads(model, xfrc_applied, qfrc_applied)
    base = state(model, keyframe, qpos, ctrl, load)
    s = element_dofs(model, flex, element) if others == "locked" else np.arange(model.nv)
    J = displacement_jacobian(model, flex, element, base, step)[:, s]
    lin = linearize(model, flex, base, Options(True, constraints, actuator_stiffness, gravity, load), step=step)
    K, M = lin.K[np.ix_(s, s)], lin.M[np.ix_(s, s)]
    N = null_space(lin.G[:, s], len(s)) if constraints == "project" else np.eye(len(s))
    Kr, Mr = N.T @ K @ N, N.T @ M @ N
    lam, phi = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    phi = N @ phi
    J = J @ N @ N.T  # the element moves only along the constrained motions
    psi = J @ phi
    strain = np.einsum("ik,ij,jk->k", psi, Ke, psi)
    elastic = lam > 1e-12 * max(lam.max(initial=0.0), 1e-300)
    stiff = np.flatnonzero(np.any(Ke != 0, axis=0))  # a direction without stiffness (a kept joint's) gets no damping
    sv = np.linalg.svd(J[stiff], compute_uv=False)
    n = int(np.sum(sv > 1e-9 * max(sv.max(initial=0.0), 1e-300)))
    share = np.where(elastic, strain / np.where(elastic, lam, 1.0), -np.inf)
    chosen = np.argsort(-share)[:n]
    if n == 0 or not np.all(elastic[chosen]) or np.any(share[chosen] <= 1e-9):
        raise ValueError(
            f"flexure {element!r}: {int(np.sum(elastic))} mode(s) of the {len(s)} dofs considered have stiffness, "
            f"but the element moves in {n} direction(s): a direction without stiffness has no damping ratio. "
            "Give the element stiffness in every direction its joints allow"
        )
    P = psi[np.ix_(stiff, chosen)]
    w = np.maximum(P * (Ke[np.ix_(stiff, stiff)] @ P), 0.0)
    w = w / np.maximum(w.sum(axis=0), 1e-300)
    zeta = r[stiff] @ w
    omega = np.sqrt(lam[chosen])
    Pp = np.linalg.pinv(P)
    B = np.zeros((6, 6))
    B[np.ix_(stiff, stiff)] = Pp.T @ np.diag(2.0 * zeta * omega) @ Pp
    B = 0.5 * (B + B.T)
    return B[np.ix_(schema.PLANAR_INDEX, schema.PLANAR_INDEX)] if record.planar else B
