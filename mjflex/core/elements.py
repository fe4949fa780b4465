r"""Visco-elastic elements between two rigid bodies: energy, wrench and dissipation.

An element joins frame ``a`` (fixed to body A, pose ``X_WA = (R_WA, p_WA)``) and frame
``b`` (fixed to body B, pose ``X_WB``); it is relaxed when the frames coincide. Its state is
the relative displacement ``X_ab = X_WA^-1 X_WB``, i.e. ``R_ab = R_WA^T R_WB`` and
``p_ab = R_WA^T (p_WB - p_WA)``, written either as

* ``method="twist"`` (paper sec. 4): the finite twist ``xi = [tau; t] = log(X_ab)``, energy
  ``U = 1/2 xi^T K xi`` (eq. 39); or
* ``method="dualquat"`` (sec. 5): the unit dual quaternion ``(sigma, xi_v) + eps (s', x')``,
  energy ``U = 2 [xi_v; x']^T K [xi_v; x']`` (eq. 80).

Both agree to second order at rest, where ``K`` is the stiffness of the element in frame
``a`` = frame ``b`` coordinates, about their common origin, angular rows first
(``K = [[K_o, K_c], [K_c^T, K_t]]``, eq. 40). The damping ``B`` acts on the rate of the same
coordinates (eqs 58-67, 96-104).

Rest pose
---------
``rest=(p_r, q_r)`` moves the relaxed state to ``X_ab = X_r`` (:mod:`mjflex.core.rest`): the
element is evaluated on frames a and b* (``X_Wb* = X_Wb X_r^-1``), its wrench moved back to
``p_WB``.

Higher-order potentials
-----------------------
``potential`` and ``wrench_on_b`` take ``terms=``, polynomial terms added to the quadratic energy
(paper secs 4.8 and 5.8; :mod:`mjflex.core.polynomial`, fitted by
:func:`mjflex.core.identification.fit_potential`). Without terms they run the quadratic kernels
unchanged.

Sign convention
---------------
:func:`wrench_on_b` returns the wrench **the element exerts on body B**,
``[moment about p_WB; force]`` in world axes. Derivation sketch: displace B by a small
world-frame twist ``delta = [d_theta; d_p]`` about ``p_WB`` (``R_WB <- exp(d_theta^) R_WB``,
``p_WB <- p_WB + d_p``); the elastic wrench is the negative gradient,
``W_B = -dU/d(delta)``, so that the virtual work ``W_B . delta = -dU``. In b coordinates this
is ``-Gamma_ab K xi`` (eq. 49, the paper's "wrench by B on the element" with the opposite
sign) or ``-2 Lambda_ab K [xi_v; x']`` (eq. 87); rotating by ``R_WB`` gives world axes (the
paper's eq. 50 also shifts the moment to the world origin; we keep it about ``p_WB``).
The element exerts the equal and opposite wrench on body A: ``-W_B`` about ``p_WB``, which
about ``p_WA`` has moment ``-m_B - (p_WB - p_WA) x f_B``. Since ``U`` only depends on
``X_ab``, the pair does no net work under a common rigid motion (momentum is conserved).
The viscous part is ``-Gamma_ab B xi_dot`` (eq. 65) or ``-2 Lambda_ab B [xi_v; x']_dot``
(eq. 102), likewise mapped; its power on the pair is ``-xi_dot^T B xi_dot`` (twist) or
``-4 [xi_v; x']_dot^T B [xi_v; x']_dot`` (dual quaternion), never positive when the
symmetric part of ``B`` is positive semi-definite; :func:`dissipation_power` returns its
negative.

Large rotations
---------------
* Twist method: defined for every relative rotation angle ``alpha`` in ``[0, pi]``; the
  logarithm is two-valued at ``alpha = pi`` (``tau = +pi u`` or ``-pi u``). We take the
  branch whose axis has its largest-magnitude component positive there, so the energy and
  wrench are well defined everywhere, but past a half turn the branch flips: the rotational
  energy ``1/2 tau^T K_o tau`` is continuous with a kink (its slope jumps from ``+`` to ``-``),
  and terms that couple to the translation (``K_c``, or ``p_ab`` not along the axis) can jump.
* Dual-quaternion method: ``U`` is even in ``q`` and smooth for every rotation, no branch
  is chosen anywhere. About a fixed axis ``u`` the rotational energy is
  ``2 sin^2(alpha/2) u^T K_o u``, which peaks at ``alpha = pi``: there the restoring moment
  about ``u`` vanishes (an unstable equilibrium), whereas the twist energy
  ``alpha^2 u^T K_o u / 2`` keeps growing. For small displacements both methods agree to first
  order in the wrench (``W ~ -K delta``, eqs 52/90); they differ at third order in the angle,
  e.g. the moment about a principal axis is ``-k alpha`` (twist, exactly, when ``K_c = 0``
  and ``p_ab = 0``) versus ``-k sin(alpha)`` (dual quaternion).
"""

import math

import numpy as np

from . import _kernels as _k
from . import _planar_kernels as _pk
from . import _poly_kernels as _polyk
from ._batch import flatten
from .polynomial import PolynomialTerms
from .rest import frame_at_rest
from .validation import as_array, check_psd_matrix, check_rotation, method_code

_SPATIAL = {  # argument -> (core shape, what)
    "R_WA": ((3, 3), "rotation"), "p_WA": ((3,), None), "R_WB": ((3, 3), "rotation"), "p_WB": ((3,), None),
    "K": ((6, 6), "stiffness"), "B": ((6, 6), "damping"),
    "w_WA": ((3,), None), "v_WA": ((3,), None), "w_WB": ((3,), None), "v_WB": ((3,), None),
}  # fmt: skip
_PLANAR = {
    "theta_WA": ((), None), "p_WA": ((2,), None), "theta_WB": ((), None), "p_WB": ((2,), None),
    "K": ((3, 3), "stiffness"), "B": ((3, 3), "damping"),
    "w_WA": ((), None), "v_WA": ((2,), None), "w_WB": ((), None), "v_WB": ((2,), None),
}  # fmt: skip
_VELOCITIES = ("w_WA", "v_WA", "w_WB", "v_WB")
#: The arguments documented as optional: None means no damping / zero velocity. Every other
#: argument is required, and None for it is a TypeError (it used to read as zeros).
_OPTIONAL = frozenset(("B", *_VELOCITIES))
# zero arguments for omitted velocities / damping; only ever read by the kernels
_ZEROS = {core: np.zeros(core) for core, _ in list(_SPATIAL.values()) + list(_PLANAR.values())}


def _prepare(spec, values, check, optional=_OPTIONAL):
    """Validate (if ``check``) and flatten the arguments named in ``spec``.

    ``values`` maps names to arguments; a missing damping ``B`` means no viscous part and
    missing velocities are zero; any other argument in ``optional`` (internal use) given as
    None is zero too, and None for the others raises TypeError. Returns
    ``(batch_shape, flat_arrays, viscous)``.
    """
    missing = [k for k, v in values.items() if v is None and k not in optional]
    if missing:
        core = spec[missing[0]][0]
        omissible = [k for k in values if k in optional]
        raise TypeError(
            f"{missing[0]} is None, but it is required: an array of shape (..., {', '.join(map(str, core))}) "
            + (f"(only {', '.join(omissible)} may be None)" if omissible else "(no argument here may be None)")
        )
    viscous = values.get("B") is not None
    if not viscous:
        given = sorted(k for k in _VELOCITIES if values.get(k) is not None)
        if given:
            raise ValueError(
                f"velocities {given} were given but B is None: pass the damping matrix B to get "
                "the viscous wrench, or drop the velocities."
            )
    arrays, leading = [], []
    for name, x in values.items():
        core, what = spec[name]
        if check and x is not None and what == "rotation":
            x = check_rotation(x, name)
        elif check and x is not None:
            x = as_array(x, name, core) if what is None else check_psd_matrix(x, name, core[0], what=what)
        a = _ZEROS[core] if x is None else np.asarray(x, dtype=np.float64, order="C")
        arrays.append(a)
        leading.append(a.shape[: a.ndim - len(core)])
    shape, flat = flatten(arrays, leading, values.keys())
    return shape, flat, viscous


def _terms_args(terms, method, K, check):
    """``(exps, coefs, pw, grad)`` for the polynomial kernels, or None without terms."""
    if terms is None:
        return None
    if not isinstance(terms, PolynomialTerms):
        raise ValueError(
            f"terms must be a mjflex.PolynomialTerms (or None for the quadratic potential); got {type(terms).__name__}"
        )
    if terms.method != method:
        raise ValueError(
            f"terms are in {terms.method!r} coordinates but method={method!r}: pass method={terms.method!r} "
            "(the terms and K of a fitted potential belong together)."
        )
    if len(terms) == 0:
        return None
    if check:
        H = terms.rest_stiffness()
        if np.any(H):
            check_psd_matrix(K + H, "K + terms.rest_stiffness()", 6, what="stiffness")
    return (terms.exponents, terms.coefficients, *_polyk.work_arrays(terms.exponents))


def _with_rest(values, rest, check):
    """``(values, shift)``: frame b replaced by frame b* of the rest pose (:mod:`mjflex.core.rest`), the velocity of
    frame b's origin moved to b*'s, and ``p_Wb* - p_WB`` (None without a rest pose)."""
    if rest is None:
        return values, None
    values = dict(values)
    R, p = values["R_WB"], values["p_WB"]
    if check:
        R, p = check_rotation(R, "R_WB"), as_array(p, "p_WB", (3,))
    values["R_WB"], values["p_WB"] = frame_at_rest(R, p, rest)
    shift = values["p_WB"] - np.asarray(p, dtype=float)
    if values.get("w_WB") is not None:
        w = as_array(values["w_WB"], "w_WB", (3,)) if check else np.asarray(values["w_WB"], dtype=float)
        v = 0.0 if values.get("v_WB") is None else np.asarray(values["v_WB"], dtype=float)
        values["v_WB"] = v + np.cross(w, shift)
    return values, shift


_WRENCH_KERNELS = (_k.spatial_wrench_batch, _polyk.spatial_wrench_terms_batch)  # without terms, with terms
_POTENTIAL_KERNELS = (_k.spatial_potential_batch, _polyk.spatial_potential_terms_batch)


def _run(spec, kernel, values, method, check, terms=None, rest=None, optional=_OPTIONAL):
    """Run a batch kernel: the energy (...), or (wrench (..., n) with the moment about p_WB, dissipated power (...))
    where ``values`` holds ``B``. ``kernel``: the planar loop, or the spatial pair (quadratic, polynomial), the first
    without terms (the second gives the same bits there, at 25 % more per element)."""
    values, shift = _with_rest(values, rest, check)
    code = method_code(method)
    shape, f, viscous = _prepare(spec, values, check, optional)
    extra = ()
    if spec is not _PLANAR:
        extra = _terms_args(terms, method, f[4], check)
        kernel, extra = (kernel[0], ()) if extra is None else (kernel[1], extra)
    n, width = math.prod(shape), spec["K"][0][0]
    if "B" not in values:
        out = np.empty(n)
        kernel(code, *f, *extra, out)
        return out.reshape(shape)[()]
    out, power = np.empty((n, width)), np.empty(n)
    kernel(code, *f[:6], viscous, *f[6:], *extra, out, power)
    W = out.reshape((*shape, width))
    if shift is not None:
        W = W + np.concatenate(np.broadcast_arrays(np.cross(shift, W[..., 3:]), np.zeros(3)), axis=-1)
    return W, power.reshape(shape)


def potential(R_WA, p_WA, R_WB, p_WB, K, *, method="twist", terms=None, rest=None, check=True):
    """Elastic energy stored in the element [J].

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    K : array_like, shape (..., 6, 6)
        Symmetric positive semi-definite stiffness at rest, in a (= b) coordinates about the
        common origin, rows ``[rotation; translation]``: units ``N m/rad``, ``N/rad``, ``N/m``.
    method : {"twist", "dualquat"}
        ``1/2 xi^T K xi`` (eq. 39) or ``2 [xi_v; x']^T K [xi_v; x']`` (eq. 80).
    terms : PolynomialTerms, optional
        Higher-order terms added to the quadratic potential (:mod:`mjflex.core.polynomial`),
        in the coordinates of ``method``; e.g. ``fit.terms`` of a fitted potential. Without
        them (or with none) the result is the quadratic potential, bit for bit.
    rest : tuple (pos, quat), optional
        The element's rest pose, the pose of frame b in frame a at which its energy is zero:
        position [m] and unit quaternion w-first (:mod:`mjflex.core.rest`). Default: the frames
        coincide.
    check : bool
        Validate the arguments (skip only for arguments validated before).

    Returns
    -------
    U : ndarray, shape (...)
        Energy [J], broadcast over the leading axes of all arguments.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 2.0, 2.0, 1e4, 1e4, 1e4])  # [N m/rad] x 3, [N/m] x 3
    >>> R_WB, p_WB = mjflex.transform_from_twist([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])  # B turned 0.1 rad about z
    >>> U = mjflex.potential(np.eye(3), np.zeros(3), R_WB, p_WB, K)  # frame a at the world origin
    >>> print(f"{U:.6f} J")  # K_zz theta^2 / 2
    0.010000 J
    """
    values = {"R_WA": R_WA, "p_WA": p_WA, "R_WB": R_WB, "p_WB": p_WB, "K": K}
    return _run(_SPATIAL, _POTENTIAL_KERNELS, values, method, check, terms, rest)


def wrench_on_b(
    R_WA, p_WA, R_WB, p_WB, K, *, method="twist", B=None,
    w_WA=None, v_WA=None, w_WB=None, v_WB=None, terms=None, rest=None, check=True,
):  # fmt: skip
    """Wrench that the element exerts on body B (elastic plus viscous).

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    K : array_like, shape (..., 6, 6)
        Stiffness at rest in a (= b) coordinates about the common origin, rows
        ``[rotation; translation]`` (see :func:`potential`).
    method : {"twist", "dualquat"}
        Displacement coordinates (module docstring).
    B : array_like, shape (..., 6, 6), optional
        Damping on the rate of the same coordinates, same layout and frame as ``K``
        (``N m s/rad``, ``N s/rad``, ``N s/m``). Without it the wrench is purely elastic.
    w_WA, w_WB : array_like, shape (..., 3), optional
        Angular velocities of frames a and b, world axes [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 3), optional
        Linear velocities of the origins of frames a and b, world axes [m/s] (what
        ``mujoco.mj_objectVelocity`` returns for a site with ``flg_local=0``, reordered as
        ``w = res[:3]``, ``v = res[3:]``). Zero when omitted; only allowed with ``B``.
    terms : PolynomialTerms, optional
        Higher-order elastic terms (see :func:`potential`); the elastic wrench becomes
        ``-Gamma_ab grad U`` (eq. 76) or ``-1/2 Lambda~_ab grad U`` (eq. 115). The viscous part
        stays quadratic.
    rest : tuple (pos, quat), optional
        The element's rest pose, the pose of frame b in frame a at which its energy is zero:
        position [m] and unit quaternion w-first (:mod:`mjflex.core.rest`). Default: the frames
        coincide.
    check : bool
        Validate the arguments (skip only for arguments validated before).

    Returns
    -------
    wrench : ndarray, shape (..., 6)
        ``[moment about p_WB; force]`` on body B in world axes [N m; N]. The element exerts
        the equal and opposite wrench on body A.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 2.0, 2.0, 1e4, 1e4, 1e4])
    >>> R_WB, p_WB = mjflex.transform_from_twist([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    >>> W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_WB, p_WB, K)
    >>> print(np.round(W, 12) + 0.0)  # [moment about b; force], world axes: it turns B back
    [ 0.   0.  -0.2  0.   0.   0. ]
    >>> W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_WB, p_WB, K, B=0.01 * K, w_WB=[0.0, 0.0, 1.0])
    >>> print(f"{W[2]:.4f} N m")  # elastic plus viscous, B spinning at 1 rad/s
    -0.2200 N m
    """
    values = dict(zip(_SPATIAL, (R_WA, p_WA, R_WB, p_WB, K, B, w_WA, v_WA, w_WB, v_WB), strict=True))
    return _run(_SPATIAL, _WRENCH_KERNELS, values, method, check, terms, rest=rest)[0]


def dissipation_power(
    R_WA, p_WA, R_WB, p_WB, B, *, method="twist", w_WA=None, v_WA=None, w_WB=None, v_WB=None, rest=None, check=True
):
    """Power dissipated by the viscous part of the element [W] (non-negative for valid B).

    Equals minus the power of the viscous wrenches on A and B together:
    ``xi_dot^T B xi_dot`` (twist) or ``4 [xi_v; x']_dot^T B [xi_v; x']_dot`` (dual
    quaternion). Arguments as in :func:`wrench_on_b`.

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    B : array_like, shape (..., 6, 6)
        Damping in a (= b) coordinates about the common origin, rows ``[rotation; translation]``
        (``N m s/rad``, ``N s/rad``, ``N s/m``).
    method : {"twist", "dualquat"}
        Displacement coordinates whose rate ``B`` damps.
    w_WA, w_WB : array_like, shape (..., 3), optional
        Angular velocities of frames a and b, world axes [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 3), optional
        Linear velocities of the origins of frames a and b, world axes [m/s]. Zero when omitted.
    rest : tuple (pos, quat), optional
        The element's rest pose, the pose of frame b in frame a at which its energy is zero:
        position [m] and unit quaternion w-first (:mod:`mjflex.core.rest`). Default: the frames
        coincide.
    check : bool
        Validate the arguments (skip only for arguments validated before).

    Returns
    -------
    power : ndarray, shape (...)
        Dissipated power [W].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> B = np.diag([0.01, 0.01, 0.01, 10.0, 10.0, 10.0])
    >>> P = mjflex.dissipation_power(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), B, w_WB=[0.0, 0.0, 2.0])
    >>> print(f"{P:.4f} W")  # B_zz omega^2 at rest
    0.0400 W
    """
    if B is None:
        raise ValueError("B is required: dissipation_power needs the damping matrix.")
    values = dict(zip(_SPATIAL, (R_WA, p_WA, R_WB, p_WB, None, B, w_WA, v_WA, w_WB, v_WB), strict=True))
    return _run(_SPATIAL, _WRENCH_KERNELS, values, method, check, optional=_OPTIONAL | {"K"},
                        rest=rest)[1][()]  # fmt: skip


# --------------------------------------------------------------------------- planar


def planar_potential(theta_WA, p_WA, theta_WB, p_WB, K, *, method="twist", check=True):
    """Elastic energy of a planar element [J] (appendices A and B).

    Parameters
    ----------
    theta_WA, theta_WB : array_like, shape (...)
        Orientation angles of frames a and b in the world plane [rad] (counter-clockwise).
    p_WA, p_WB : array_like, shape (..., 2)
        Origins of frames a and b in world coordinates [m].
    K : array_like, shape (..., 3, 3)
        Stiffness at rest in a (= b) coordinates about the common origin, ordered
        ``[theta; x; y]`` (``N m/rad``, ``N/rad``, ``N/m``).
    method : {"twist", "dualquat"}
        Planar twist (eq. 132) or planar Clifford-algebra (planar dual quaternion) energy.
    check : bool
        Validate the arguments.

    Returns
    -------
    U : ndarray, shape (...)
        Energy [J]. Equals :func:`potential` of the same motion embedded in the x-y plane
        with ``K`` in rows/columns ``(2, 3, 4)`` of a 6x6 matrix.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 1e4, 1e4])  # [theta; x; y]: N m/rad, N/m, N/m
    >>> print(f"{mjflex.planar_potential(0.0, [0.0, 0.0], 0.1, [0.0, 0.0], K):.6f} J")
    0.010000 J
    """
    values = {"theta_WA": theta_WA, "p_WA": p_WA, "theta_WB": theta_WB, "p_WB": p_WB, "K": K}
    return _run(_PLANAR, _pk.planar_potential_batch, values, method, check)


def planar_wrench_on_b(
    theta_WA, p_WA, theta_WB, p_WB, K, *, method="twist", B=None,
    w_WA=None, v_WA=None, w_WB=None, v_WB=None, check=True,
):  # fmt: skip
    """Wrench that a planar element exerts on body B.

    Parameters
    ----------
    theta_WA, theta_WB, p_WA, p_WB, K, method, check
        As in :func:`planar_potential`.
    B : array_like, shape (..., 3, 3), optional
        Damping, same layout as ``K`` (``N m s/rad``, ``N s/rad``, ``N s/m``).
    w_WA, w_WB : array_like, shape (...), optional
        Angular velocities of frames a and b [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 2), optional
        Linear velocities of the origins of frames a and b, world axes [m/s].

    Returns
    -------
    wrench : ndarray, shape (..., 3)
        ``[moment about p_WB; fx; fy]`` on body B, world axes [N m; N; N].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 1e4, 1e4])
    >>> print(np.round(mjflex.planar_wrench_on_b(0.0, [0.0, 0.0], 0.0, [0.001, 0.0], K), 12) + 0.0)  # [moment; fx; fy]
    [  0. -10.   0.]
    """
    values = dict(zip(_PLANAR, (theta_WA, p_WA, theta_WB, p_WB, K, B, w_WA, v_WA, w_WB, v_WB), strict=True))
    return _run(_PLANAR, _pk.planar_wrench_batch, values, method, check)[0]


def planar_dissipation_power(
    theta_WA, p_WA, theta_WB, p_WB, B, *, method="twist", w_WA=None, v_WA=None, w_WB=None, v_WB=None, check=True
):
    """Power dissipated by a planar element [W]; arguments as in :func:`planar_wrench_on_b`.

    Parameters
    ----------
    theta_WA, theta_WB : array_like, shape (...)
        Orientations of frames a and b in the plane [rad].
    p_WA, p_WB : array_like, shape (..., 2)
        Origins of frames a and b in world coordinates [m].
    B : array_like, shape (..., 3, 3)
        Damping, rows ``[theta; x; y]`` (``N m s/rad``, ``N s/rad``, ``N s/m``).
    method : {"twist", "dualquat"}
        Displacement coordinates whose rate ``B`` damps.
    w_WA, w_WB : array_like, shape (...), optional
        Angular velocities of frames a and b [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 2), optional
        Linear velocities of the origins of frames a and b, world axes [m/s]. Zero when omitted.
    check : bool
        Validate the arguments (skip only for arguments validated before).

    Returns
    -------
    power : ndarray, shape (...)
        Dissipated power [W].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> B = np.diag([0.01, 10.0, 10.0])
    >>> P = mjflex.planar_dissipation_power(0.0, [0.0, 0.0], 0.0, [0.0, 0.0], B, v_WB=[0.1, 0.0])
    >>> print(f"{P:.4f} W")
    0.1000 W
    """
    if B is None:
        raise ValueError("B is required: planar_dissipation_power needs the damping matrix.")
    values = dict(zip(_PLANAR, (theta_WA, p_WA, theta_WB, p_WB, None, B, w_WA, v_WA, w_WB, v_WB), strict=True))
    return _run(_PLANAR, _pk.planar_wrench_batch, values, method, check, optional=_OPTIONAL | {"K"})[1][()]
