"""Argument checks at the boundary of the core (never called inside the compiled kernels).

The one place where arguments become numbers: every public function of :mod:`mjflex.core`
converts its array arguments with :func:`as_array` (or :func:`check_rotation`,
:func:`check_psd_matrix`, :func:`check_unit_dual_quaternion`, which use it), the MuJoCo layer
converts element records (:mod:`mjflex.mjcf.schema`) and ``add_flexure``'s arguments with the same
functions, and scalar options everywhere go through :func:`check_number` and :func:`check_flag`.

Conversion rules (:func:`numeric_array`), the same for arrays, nested lists and JSON data:

* accepted: real numbers: Python ``int`` and ``float``, numpy integer and floating scalars and
  arrays, and nested lists / tuples of them (any other object that converts with ``float``,
  e.g. ``fractions.Fraction``, too); they become float64;
* rejected with :class:`ValueError` naming the argument and the index of the first bad entry:
  booleans (``True`` is not the number 1 here: a flag given where a number belongs is a
  mistake), text (``"0.3"``: numpy would parse it, silently), ``None``, complex numbers (numpy
  would drop the imaginary part with a warning only), integers beyond float64's range (a
  401-digit integer), and anything else that is not a real number (dates, bytes, objects);
* an argument that is required may not be ``None`` (``TypeError``); only what a function
  documents as optional may be.

Every check raises an error whose message names the argument (and the batch index
of the first offending element), shows the offending value shortened to ``SHORT_REPR``
characters (:func:`shorten`), and says how to fix it.

Tolerances, all relative so that they do not depend on units:

* symmetry: ``|M_ij - M_ji| <= SYMMETRY_RTOL * sqrt(|M_ii M_jj|)`` (for a positive
  semi-definite matrix ``|M_ij| <= sqrt(M_ii M_jj)``, so this is relative to the entry's
  natural scale whatever units rows and columns carry);
* positive semi-definiteness: the smallest eigenvalue of the diagonally scaled matrix
  ``S M S``, ``S = diag(M_ii)^(-1/2)``, must be ``>= -PSD_RTOL`` (scale-invariant);
* rotations: ``max |R^T R - I| <= ORTHONORMAL_ATOL`` and ``det R > 0``; for input of a
  lower precision (float32, float16) the bound is ``ORTHONORMAL_EPS_FACTOR`` times its machine
  epsilon instead, i.e. a rotation orthonormal to the precision it was given in is accepted
  (and used in float64 as given);
* unit dual quaternions: ``| |q_r| - 1 | <= UNIT_ATOL`` and
  ``|q_r . q_d| <= UNIT_ATOL * max(1, |q_d|)``.
"""

import math
import numbers

import numpy as np

from ._kernels import DUALQUAT, TWIST

SYMMETRY_RTOL = 1e-8
PSD_RTOL = 1e-10
#: Largest magnitude of a K or B entry (and of a stop's stiffness): an element's energy ``x^T K x / 2``
#: and power stay finite in float64 for every displacement and velocity MuJoCo accepts
#: (``|x| <= 1e10``, its ``mjMAXVAL``). The C library's ``MJFX_MAX_MATRIX_ENTRY``, held equal by a test.
MAX_MATRIX_ENTRY = 1e280
ORTHONORMAL_ATOL = 1e-9
ORTHONORMAL_EPS_FACTOR = 16
UNIT_ATOL = 1e-9
#: Longest quotation of a bad value in an error message [characters] (a 500 kB list is cut).
SHORT_REPR = 80

_ORTHO_FIX = "re-orthonormalize it, e.g. scipy.spatial.transform.Rotation.from_matrix(R).as_matrix()"


def _where(name: str, index: tuple) -> str:
    return f"{name}[{', '.join(str(int(i)) for i in index)}]" if index else name


def shorten(value, limit: int = SHORT_REPR) -> str:
    """``repr(value)`` cut to ``limit`` characters, saying how long it was, for error messages."""
    text = np.array2string(value, threshold=20) if isinstance(value, np.ndarray) else repr(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}... ({len(text)} characters)"


def _leaf_problem(x, path):
    """``(path, what)`` of the first entry of ``x`` that is not a real number, or None."""
    if isinstance(x, list | tuple):
        for i, v in enumerate(x):
            found = _leaf_problem(v, (*path, i))
            if found:
                return found
        return None
    if isinstance(x, np.ndarray):
        if x.dtype.kind in "iuf":
            return None
        if x.dtype.kind != "O":
            return path, "holds " + _dtype_problem(x.dtype)
        for i, v in enumerate(x.flat):
            found = _leaf_problem(v, (*path, *np.unravel_index(i, x.shape)))
            if found:
                return found
        return None
    problem = _scalar_problem(x)
    return (path, "is " + problem) if problem else None


def _dtype_problem(dtype) -> str:
    kinds = {"b": "booleans", "c": "complex numbers", "U": "text", "S": "bytes", "M": "dates", "m": "time spans"}
    return f"{kinds.get(dtype.kind, 'values of another kind')} (dtype {dtype})"


def _scalar_problem(v) -> str | None:
    if isinstance(v, bool | np.bool_):
        return f"the boolean {v!r}"
    if v is None:
        return "None"
    if isinstance(v, str | bytes):
        return f"the text {shorten(v, 40)}"
    if isinstance(v, complex | np.complexfloating):
        return f"the complex number {v!r}"
    if isinstance(v, numbers.Integral) and not isinstance(v, np.integer):
        return None if abs(int(v)) <= _FLOAT_MAX_INT else f"an integer of {_digits(int(v))} digits"
    if isinstance(v, numbers.Real):
        return None
    try:
        float(v)
    except (TypeError, ValueError, OverflowError):
        return f"{shorten(v, 40)} ({type(v).__name__})"
    return None


_FLOAT_MAX_INT = int(np.finfo(np.float64).max)


def _digits(n: int) -> int:
    """Decimal digits of ``n`` without ``str(n)`` (which Python refuses beyond 4300 digits)."""
    return len(str(abs(n))) if n.bit_length() < 10000 else int(n.bit_length() * math.log10(2)) + 1


_NOT_NUMBER_FIX = "numbers are expected: ints or floats, not booleans, text, None or complex numbers"


def numeric_array(x, name: str) -> np.ndarray:
    """``x`` as a float64 array (any shape) if every entry is a real number; see the module notes.

    Raises ValueError naming ``name``, the index of the first bad entry and what it is.
    """
    if x is None:
        raise TypeError(f"{name} is None: it is required ({_NOT_NUMBER_FIX})")
    if not (isinstance(x, np.ndarray) and x.dtype.kind in "iuf"):
        try:
            found = _leaf_problem(x, ())
        except RecursionError:
            raise ValueError(f"{name} is nested too deeply to be an array of numbers") from None
        if found:
            path, what = found
            where = _where(name, path)
            if what.startswith("is an integer of"):
                raise ValueError(f"{where} {what}: beyond float64's range (about 1.8e308); check its units")
            fix = " (np.real(x) if the imaginary part is meant to be dropped)" if "complex" in what else ""
            got = "" if what.startswith("holds") else f"; got {shorten(x)}"
            raise ValueError(f"{where} {what}: {_NOT_NUMBER_FIX}{fix}{got}")
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} must be a numeric array: {exc}; got {shorten(x)}") from None


def as_array(x, name: str, core_shape: tuple[int, ...]) -> np.ndarray:
    """``x`` as a float64 array of shape ``(..., *core_shape)`` with finite entries."""
    a = numeric_array(x, name)
    n = len(core_shape)
    if a.ndim < n or a.shape[a.ndim - n :] != tuple(core_shape):
        raise ValueError(f"{name} must have shape (..., {', '.join(map(str, core_shape))}); got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{name} contains a non-finite value ({float(a[idx])} at index {list(idx)}). Poses, velocities "
            "and parameters must be finite; a NaN state usually means that a simulation diverged "
            "(reduce the time step or check the initial state)."
        )
    return a


def check_number(value, name: str, *, integer=False, above=None, at_least=None, below=None, at_most=None):
    """``value`` as a float (an int with ``integer``), checked: a finite real number in range.

    TypeError unless a real number (booleans, text, None and complex numbers are not; with
    ``integer``, nor is 2.5 or 2.0); ValueError if not finite or outside ``> above``,
    ``>= at_least``, ``< below``, ``<= at_most``. The message names ``name`` and the bound.
    """
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    problem = _scalar_problem(value) if not isinstance(value, np.ndarray) else "an array"
    kind = "an integer" if integer else "a number"
    if problem and not problem.startswith("an integer of"):
        raise TypeError(f"{name} must be {kind}; got {problem}")
    if integer and not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be {kind}; got {shorten(value)} ({type(value).__name__})")
    if problem:
        raise ValueError(f"{name} is {problem}, beyond float64's range; check it")
    number = int(value) if integer else float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    bounds = [(b, op, text) for b, op, text in ((above, float.__gt__, ">"), (at_least, float.__ge__, ">="),
              (below, float.__lt__, "<"), (at_most, float.__le__, "<=")) if b is not None]  # fmt: skip
    if not all(op(float(number), float(b)) for b, op, _ in bounds):
        raise ValueError(f"{name} must be {' and '.join(f'{text} {b:g}' for b, _, text in bounds)}; got {value!r}")
    return number


def check_flag(value, name: str) -> bool:
    """``value`` as a bool; TypeError unless it is one (``True``/``False`` or a numpy bool).

    Strings such as ``"false"`` and numbers are refused: ``bool("false")`` is True.
    """
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise TypeError(f"{name} must be True or False; got {shorten(value)} ({type(value).__name__})")


def _first(mask: np.ndarray) -> tuple:
    return tuple(np.argwhere(mask)[0]) if mask.ndim else ()


def check_rotation(R, name: str) -> np.ndarray:
    """Validated rotation matrices ``(..., 3, 3)`` (float64; see the module notes for float32 input)."""
    given = np.asarray(R).dtype if hasattr(R, "dtype") else np.dtype(np.float64)
    low = np.issubdtype(given, np.floating) and np.finfo(given).eps > np.finfo(np.float64).eps
    tol = max(ORTHONORMAL_ATOL, ORTHONORMAL_EPS_FACTOR * float(np.finfo(given).eps)) if low else ORTHONORMAL_ATOL
    R = as_array(R, name, (3, 3))
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2))
    bad = err > tol
    if bad.any():
        i = _first(bad)
        raise ValueError(
            f"{_where(name, i)} is not a rotation matrix: max |R^T R - I| = {err[i]:.3g} exceeds "
            f"{tol:g} (for its dtype {given}); {_ORTHO_FIX}"
            + (", in float64 (np.asarray(R, dtype=np.float64))." if low else ".")
        )
    det = np.linalg.det(R)
    bad = det <= 0
    if bad.any():
        i = _first(bad)
        raise ValueError(
            f"{_where(name, i)} has determinant {det[i]:.3g}: it is a reflection, not a rotation. "
            "Flip the sign of one axis (column) so that the frame is right-handed."
        )
    return R


def check_psd_matrix(M, name: str, n: int, *, what: str) -> np.ndarray:
    """Validated symmetric positive semi-definite ``(..., n, n)`` matrices.

    ``what`` is ``"stiffness"`` or ``"damping"`` and only changes the advice in messages.
    """
    M = as_array(M, name, (n, n))
    diag = np.abs(np.diagonal(M, axis1=-2, axis2=-1))
    root = np.sqrt(diag)  # sqrt(M_ii) sqrt(M_jj): no overflow of the product for entries up to 1e308
    scale = root[..., :, None] * root[..., None, :]
    asym = np.abs(M - np.swapaxes(M, -1, -2)) / np.maximum(scale, np.finfo(float).tiny)
    bad = asym > SYMMETRY_RTOL
    if bad.any():
        idx = tuple(np.argwhere(bad)[0])
        i, (r, c) = idx[:-2], idx[-2:]
        where = _where(name, i)
        raise ValueError(
            f"{where} is not symmetric: {where}[{r}, {c}] = {M[idx]:.6g} but {where}[{c}, {r}] = "
            f"{M[i + (c, r)]:.6g} (relative asymmetry {asym[idx]:.3g} > {SYMMETRY_RTOL:g}). A {what} "
            "matrix must be symmetric; if the difference is round-off, pass (M + M.T) / 2 "
            "(M + np.swapaxes(M, -1, -2) for batches)."
        )
    s = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
    scaled = s[..., :, None] * (0.5 * (M + np.swapaxes(M, -1, -2))) * s[..., None, :]
    lam = np.linalg.eigvalsh(scaled)[..., 0]
    bad = lam < -PSD_RTOL
    if bad.any():
        i = _first(bad)
        where = _where(name, i)
        w, v = np.linalg.eigh(M[i])
        advice = (
            "check the signs of the coupling block K_c (rows 0-2, columns 3-5 for 6x6; row 0, "
            "columns 1-2 for 3x3), or project onto the PSD cone (clip negative eigenvalues) if it "
            "comes from a noisy identification"
            if what == "stiffness"
            else "a damping with an indefinite symmetric part generates energy; check its signs"
        )
        raise ValueError(
            f"{where} is not positive semi-definite: its smallest eigenvalue is {w[0]:.6g} "
            f"(eigenvector {np.array2string(v[:, 0], precision=3)}), i.e. {lam[i]:.3g} relative to "
            f"its diagonal (tolerance {PSD_RTOL:g}). A {what} matrix must be positive "
            f"semi-definite: {advice}."
        )
    return M


def check_unit_dual_quaternion(q, name: str) -> np.ndarray:
    """Validated unit dual quaternions ``(..., 8)``."""
    q = as_array(q, name, (8,))
    qr, qd = q[..., :4], q[..., 4:]
    norm_err = np.abs(np.linalg.norm(qr, axis=-1) - 1.0)
    ortho_err = np.abs(np.sum(qr * qd, axis=-1)) / np.maximum(1.0, np.linalg.norm(qd, axis=-1))
    bad = (norm_err > UNIT_ATOL) | (ortho_err > UNIT_ATOL)
    if bad.any():
        i = _first(bad)
        raise ValueError(
            f"{_where(name, i)} is not a unit dual quaternion: | |q_r| - 1 | = {norm_err[i]:.3g} and "
            f"|q_r . q_d| = {ortho_err[i]:.3g} (tolerance {UNIT_ATOL:g}). Build it with "
            "dual_quaternion_from_transform, or normalize: q_r /= |q_r|, then remove from q_d its "
            "component along q_r."
        )
    return q


#: Method name -> the code the kernels take; ``METHOD_NAMES`` is the reverse.
METHOD_CODES = {"twist": TWIST, "dualquat": DUALQUAT}
METHOD_NAMES = {code: name for name, code in METHOD_CODES.items()}


def method_code(method: str, name: str = "method") -> int:
    """0 for ``"twist"``, 1 for ``"dualquat"``."""
    code = METHOD_CODES.get(method) if isinstance(method, str) else None
    if code is None:
        raise ValueError(f"{name} must be 'twist' or 'dualquat'; got {method!r}.")
    return code
