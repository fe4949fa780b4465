"""Compiled kernels of the planar elements (paper appendices A and B; numba, no mujoco).

Planar displacement ``(theta, p)`` in the x-y plane; 3-vectors ``[theta; x; y]``; ``J v`` turns
``v`` by +90 degrees. These are the spatial formulas of :mod:`._kernels` restricted to the plane
(``tau = theta e_z``, ``t`` in-plane), written out so that the planar case costs a fraction of
the spatial one; ``tests/test_element_properties.py`` checks the two against each other.
"""

import math

from numba import njit

from ._kernels import PI, TWIST, TWO_PI, flat_rows, jl_inv_coefs, load9, row_of


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def wrap_angle(d):
    """Angle wrapped to (-pi, pi]."""
    if d > PI or d <= -PI:
        d = d - TWO_PI * math.floor((d + PI) / TWO_PI)
        if d <= -PI:
            d += TWO_PI
    return d


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _cross2(a, b):
    return a[0] * b[1] - a[1] * b[0]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _rot2_t(th, v):
    """``R(th)^T v``."""
    c, s = math.cos(th), math.sin(th)
    return (c * v[0] + s * v[1], -s * v[0] + c * v[1])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _lin2(ca, a, cb, b):
    return (ca * a[0] + cb * b[0], ca * a[1] + cb * b[1])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _perp(v):
    """``J v``: ``v`` turned by +90 degrees (``e_z x v``)."""
    return (-v[1], v[0])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _mat3_vec(M, s, v):
    """``M @ [s; v]`` for a row-major 9-tuple ``M``, as ``(scalar, 2-tuple)``."""
    a = M[0] * s + M[1] * v[0] + M[2] * v[1]
    b = M[3] * s + M[4] * v[0] + M[5] * v[1]
    c = M[6] * s + M[7] * v[0] + M[8] * v[1]
    return a, (b, c)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _planar_coords(method, th_a, p_WA, th_b, p_WB):
    """Planar displacement coordinates ``(e1, e2, aux)`` (appendices A and B)."""
    th = wrap_angle(th_b - th_a)
    p = _rot2_t(th_a, (p_WB[0] - p_WA[0], p_WB[1] - p_WA[1]))
    if method == TWIST:
        c = jl_inv_coefs(abs(th), math.cos(0.5 * th), abs(math.sin(0.5 * th)))[0]
        k = 1.0 - c * th * th  # (th/2) cot(th/2)
        return th, _lin2(k, p, -0.5 * th, _perp(p)), (c, k)
    sig, xi = math.cos(0.5 * th), math.sin(0.5 * th)
    return xi, _lin2(0.5 * sig, p, -0.5 * xi, _perp(p)), (sig, 0.0)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def planar_potential(method, th_a, p_WA, th_b, p_WB, K):
    e1, e2, _ = _planar_coords(method, th_a, p_WA, th_b, p_WB)
    y1, y2 = _mat3_vec(K, e1, e2)
    scale = 0.5 if method == TWIST else 2.0
    return scale * (e1 * y1 + e2[0] * y2[0] + e2[1] * y2[1])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _planar_rate(method, e1, e2, aux, th_a, th_b, w_a, v_WA, w_b, v_WB):
    va = _rot2_t(th_a, v_WA)
    vb = _rot2_t(th_b, v_WB)
    if method == TWIST:
        th, t, c, k = e1, e2, aux[0], aux[1]
        jt = _perp(t)
        rb = _lin2(w_b, _lin2(-0.5, jt, c * th, t), 1.0, _lin2(k, vb, 0.5 * th, _perp(vb)))
        ra = _lin2(w_a, _lin2(0.5, jt, c * th, t), 1.0, _lin2(k, va, -0.5 * th, _perp(va)))
        return w_b - w_a, _lin2(1.0, rb, -1.0, ra)
    xi, xd, sig = e1, e2, aux[0]
    jx = _perp(xd)
    rb = _lin2(-w_b, jx, 1.0, _lin2(sig, vb, xi, _perp(vb)))
    ra = _lin2(w_a, jx, 1.0, _lin2(sig, va, -xi, _perp(va)))
    return 0.5 * sig * (w_b - w_a), _lin2(0.5, rb, -0.5, ra)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def planar_wrench(method, th_a, p_WA, th_b, p_WB, K, B, viscous, w_a, v_WA, w_b, v_WB):
    """Planar wrench on body B: ``(moment, (fx, fy), power)`` in world axes."""
    e1, e2, aux = _planar_coords(method, th_a, p_WA, th_b, p_WB)
    y1, y2 = _mat3_vec(K, e1, e2)
    power = 0.0
    if viscous:
        r1, r2 = _planar_rate(method, e1, e2, aux, th_a, th_b, w_a, v_WA, w_b, v_WB)
        b1, b2 = _mat3_vec(B, r1, r2)
        power = r1 * b1 + r2[0] * b2[0] + r2[1] * b2[1]
        y1 = y1 + b1
        y2 = _lin2(1.0, y2, 1.0, b2)
    if method == TWIST:
        th, t, c, k = e1, e2, aux[0], aux[1]
        m = y1 - 0.5 * _cross2(t, y2) + c * th * (t[0] * y2[0] + t[1] * y2[1])
        f = _lin2(k, y2, -0.5 * th, _perp(y2))
    else:
        xi, xd, sig = e1, e2, aux[0]
        m = 2.0 * (sig * y1 - _cross2(xd, y2))
        f = _lin2(2.0 * sig, y2, -2.0 * xi, _perp(y2))
        power *= 4.0
    cb, sb = math.cos(th_b), math.sin(th_b)
    return -m, (-(cb * f[0] - sb * f[1]), -(sb * f[0] + cb * f[1])), power


# batch loops (arrays with a leading batch axis of length n or 1)


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def _load2(a, i):
    """2-tuple ``a[i']`` of an (n, 2) array, broadcasting a leading axis of 1."""
    j = row_of(a, i)
    return (a[j, 0], a[j, 1])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def planar_wrench_batch(method, th_a, p_WA, th_b, p_WB, K, B, viscous, w_a, v_WA, w_b, v_WB, out, power):
    K, B = flat_rows(K), flat_rows(B)
    for i in range(out.shape[0]):
        m, f, power[i] = planar_wrench(
            method,
            th_a[row_of(th_a, i)],
            _load2(p_WA, i),
            th_b[row_of(th_b, i)],
            _load2(p_WB, i),
            load9(K, row_of(K, i)),
            load9(B, row_of(B, i)),
            viscous,
            w_a[row_of(w_a, i)],
            _load2(v_WA, i),
            w_b[row_of(w_b, i)],
            _load2(v_WB, i),
        )
        out[i, 0], out[i, 1], out[i, 2] = m, f[0], f[1]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def planar_potential_batch(method, th_a, p_WA, th_b, p_WB, K, out):
    K = flat_rows(K)
    for i in range(out.shape[0]):
        out[i] = planar_potential(
            method,
            th_a[row_of(th_a, i)],
            _load2(p_WA, i),
            th_b[row_of(th_b, i)],
            _load2(p_WB, i),
            load9(K, row_of(K, i)),
        )
