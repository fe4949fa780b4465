"""Compiled kernels of polynomial potentials (numba ``nopython``; no mujoco).

Terms are a table ``exps`` (rows of exponents, 6 or more columns) with coefficients ``coefs``;
an element uses rows ``lo:hi``, whose largest exponent is ``top``. ``pw`` is a work array of
shape ``(8, >= top + 1)`` holding the powers ``z_k^p`` of the element's coordinates and ``grad``
a work array of 16 entries: callers allocate both once (the MuJoCo loop on its stack), so
nothing is allocated per element. Without terms (``hi <= lo``) the kernels
return exactly what the quadratic kernels of :mod:`._kernels` return (they call them).

Wrench of the terms (see :mod:`mjflex.core.polynomial`): ``-Gamma g`` (twist) or
``-1/2 Lambda~ g`` (dual quaternion). For the dual quaternion the ``xi``/``x'`` components are
folded into the quadratic generalized forces (``-1/2 Lambda g = -2 Lambda (g / 4)``) and the
``sigma``/``s'`` columns of eq. 116 added explicitly.
"""

import numpy as np
from numba import njit

from ._kernels import (
    TWIST,
    coords,
    dot,
    flat_rows,
    force_map,
    generalized_forces,
    lin,
    lin3,
    load3,
    load9,
    load36,
    mat6_vec,
    row_of,
    spatial_potential,
    spatial_wrench,
    to_world,
)

_JIT = {"cache": True, "error_model": "numpy", "fastmath": {"contract"}}
_I9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_Z3 = (0.0, 0.0, 0.0)


@njit(**_JIT)
def _set_powers(pw, k, x, top):
    v = 1.0
    pw[k, 0] = 1.0
    for p in range(1, top + 1):
        v *= x
        pw[k, p] = v


@njit(**_JIT)
def fill_powers(method, e1, e2, aux, pw, top):
    """Powers ``0..top`` of the coordinates ``z`` into ``pw``; returns the number of coordinates."""
    if method == TWIST:
        for k in range(3):
            _set_powers(pw, k, e1[k], top)
            _set_powers(pw, 3 + k, e2[k], top)
        return 6
    _set_powers(pw, 0, aux[0], top)
    _set_powers(pw, 4, aux[1], top)
    for k in range(3):
        _set_powers(pw, 1 + k, e1[k], top)
        _set_powers(pw, 5 + k, e2[k], top)
    return 8


@njit(**_JIT)
def terms_eval(nvar, exps, coefs, lo, hi, pw, grad, want_grad):
    """Value of the terms ``lo:hi``; their gradient ``dU/dz`` into ``grad[:nvar]`` if ``want_grad``.

    ``grad`` has ``2 * 8`` entries: the second half holds the suffix products of one term, so that
    each term's gradient costs ``O(nvar)`` (prefix times suffix, no division by a coordinate).
    """
    if want_grad:
        for k in range(nvar):
            grad[k] = 0.0
    value = 0.0
    for m in range(lo, hi):
        c = coefs[m]
        if not want_grad:
            v = c
            for k in range(nvar):
                v *= pw[k, exps[m, k]]
            value += v
            continue
        suffix = 1.0
        for k in range(nvar - 1, -1, -1):
            grad[8 + k] = suffix
            suffix *= pw[k, exps[m, k]]
        value += c * suffix
        prefix = c
        for k in range(nvar):
            ek = exps[m, k]
            if ek > 0:
                grad[k] += prefix * ek * pw[k, ek - 1] * grad[8 + k]
            prefix *= pw[k, ek]
    return value


@njit(**_JIT)
def _terms_wrench_b(method, e1, e2, aux, y1, y2, grad):
    """``(m, f, scale)`` of the quadratic forces ``[y1; y2]`` plus the terms' gradient ``grad``."""
    if method == TWIST:
        y1 = lin(1.0, y1, 1.0, (grad[0], grad[1], grad[2]))
        y2 = lin(1.0, y2, 1.0, (grad[3], grad[4], grad[5]))
        return force_map(method, e1, e2, aux, y1, y2)
    y1 = lin(1.0, y1, 0.25, (grad[1], grad[2], grad[3]))
    y2 = lin(1.0, y2, 0.25, (grad[5], grad[6], grad[7]))
    m, f, scale = force_map(method, e1, e2, aux, y1, y2)
    # sigma and s' columns of eq. 116, times 1/4 because scale = -2 stands for -1/2
    m = lin3(1.0, m, -0.25 * grad[0], e1, -0.25 * grad[4], e2)
    f = lin(1.0, f, -0.25 * grad[4], e1)
    return m, f, scale


@njit(**_JIT)
def spatial_potential_terms(method, R_WA, p_WA, R_WB, p_WB, K, exps, coefs, lo, hi, top, pw, grad):
    """Elastic energy of one element with polynomial terms [J]; ``top``: largest exponent of its terms."""
    if hi <= lo:
        return spatial_potential(method, R_WA, p_WA, R_WB, p_WB, K)
    e1, e2, aux = coords(method, R_WA, p_WA, R_WB, p_WB)
    y1, y2 = mat6_vec(K, e1, e2)
    scale = 0.5 if method == TWIST else 2.0
    nvar = fill_powers(method, e1, e2, aux, pw, top)
    return scale * (dot(e1, y1) + dot(e2, y2)) + terms_eval(nvar, exps, coefs, lo, hi, pw, grad, False)


@njit(**_JIT)
def spatial_wrench_terms(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB,
                         exps, coefs, lo, hi, top, pw, grad):  # fmt: skip
    """Wrench of one element with polynomial terms on body B, and its dissipated power.

    As :func:`._kernels.spatial_wrench` (which it returns unchanged without terms).
    """
    if hi <= lo:
        return spatial_wrench(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB)
    e1, e2, aux, y1, y2, power = generalized_forces(
        method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB
    )
    nvar = fill_powers(method, e1, e2, aux, pw, top)
    terms_eval(nvar, exps, coefs, lo, hi, pw, grad, True)
    m, f, scale = _terms_wrench_b(method, e1, e2, aux, y1, y2, grad)
    return to_world(method, m, f, scale, R_WB, power)


# --------------------------------------------------------------------------- batch loops


def work_arrays(exps):
    """``(pw, grad)`` work arrays for the terms ``exps``."""
    top = int(exps.max(initial=0)) if exps.size else 0
    return np.empty((8, max(top, 1) + 1)), np.empty(16)


@njit(**_JIT)
def spatial_wrench_terms_batch(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB,
                               exps, coefs, pw, grad, out, power):  # fmt: skip
    R_WA, R_WB, K, B = flat_rows(R_WA), flat_rows(R_WB), flat_rows(K), flat_rows(B)
    hi, top = coefs.shape[0], pw.shape[1] - 1
    for i in range(out.shape[0]):
        m, f, power[i] = spatial_wrench_terms(
            method, load9(R_WA, row_of(R_WA, i)), load3(p_WA, row_of(p_WA, i)), load9(R_WB, row_of(R_WB, i)),
            load3(p_WB, row_of(p_WB, i)), load36(K, row_of(K, i)), load36(B, row_of(B, i)), viscous,
            load3(w_WA, row_of(w_WA, i)), load3(v_WA, row_of(v_WA, i)), load3(w_WB, row_of(w_WB, i)),
            load3(v_WB, row_of(v_WB, i)),
            exps, coefs, 0, hi, top, pw, grad,
        )  # fmt: skip
        for j in range(3):
            out[i, j] = m[j]
            out[i, 3 + j] = f[j]


@njit(**_JIT)
def spatial_potential_terms_batch(method, R_WA, p_WA, R_WB, p_WB, K, exps, coefs, pw, grad, out):
    R_WA, R_WB, K = flat_rows(R_WA), flat_rows(R_WB), flat_rows(K)
    hi, top = coefs.shape[0], pw.shape[1] - 1
    for i in range(out.shape[0]):
        out[i] = spatial_potential_terms(
            method, load9(R_WA, row_of(R_WA, i)), load3(p_WA, row_of(p_WA, i)), load9(R_WB, row_of(R_WB, i)),
            load3(p_WB, row_of(p_WB, i)), load36(K, row_of(K, i)), exps, coefs, 0, hi, top, pw, grad,
        )  # fmt: skip


@njit(**_JIT)
def design_batch(method, R_ab, p_ab, exps, factors, pw, grad, wrench_out, value_out):
    """Wrench and value of each monomial ``factors[m] z^exps[m]`` at each relative pose.

    ``wrench_out[i, :, m]``: the wrench that the monomial alone exerts on B, in b coordinates
    about b's origin; ``value_out[i, m]``: its value. ``(R_ab[i], p_ab[i])`` is the pose of b in a.
    """
    R_ab = flat_rows(R_ab)
    for i in range(R_ab.shape[0]):
        e1, e2, aux = coords(method, _I9, _Z3, load9(R_ab, i), load3(p_ab, i))
        nvar = fill_powers(method, e1, e2, aux, pw, pw.shape[1] - 1)
        for m in range(exps.shape[0]):
            value_out[i, m] = terms_eval(nvar, exps, factors, m, m + 1, pw, grad, True)
            mm, ff, scale = _terms_wrench_b(method, e1, e2, aux, _Z3, _Z3, grad)
            for j in range(3):
                wrench_out[i, j, m] = scale * mm[j]
                wrench_out[i, 3 + j, m] = scale * ff[j]
