"""Shared test helpers: random frames and stiffnesses, and an independent finite-difference gradient."""

import itertools

import numpy as np
from scipy.spatial.transform import Rotation

# The 24 proper rotations that permute and flip axes: products with them are exact in
# floating point, so relative displacements built on them keep full relative precision.
_SIGNED_PERMUTATIONS = [
    P
    for perm in itertools.permutations(range(3))
    for signs in itertools.product((1.0, -1.0), repeat=3)
    if np.linalg.det(P := np.eye(3)[list(perm)] * np.array(signs)[:, None]) > 0
]


def random_rotation(rng, angle=None):
    """A random rotation matrix; with ``angle`` given, a random axis at that angle [rad]."""
    if angle is None:
        return Rotation.random(random_state=rng).as_matrix()
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return Rotation.from_rotvec(angle * axis).as_matrix()


def exact_rotation(rng):
    """A random signed-permutation rotation (exact products)."""
    return _SIGNED_PERMUTATIONS[rng.integers(len(_SIGNED_PERMUTATIONS))]


def random_spd(rng, n=6, cond=1e2, scales=None):
    """Random symmetric positive definite matrix with couplings and condition ~cond.

    ``scales`` (length n) rescales rows/columns (``D K D``), e.g. to mimic physical units.
    """
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    lam = np.geomspace(1.0, cond, n)
    K = Q @ np.diag(lam) @ Q.T
    if scales is not None:
        d = np.asarray(scales, dtype=float)
        K = d[:, None] * K * d[None, :]
    return 0.5 * (K + K.T)


def rot_exp(w):
    """Rotation matrix of a rotation vector (scipy, independent of mjflex)."""
    return Rotation.from_rotvec(w).as_matrix()


def ridders(f, h0, ntab=12, con=1.4):
    """Derivative of scalar ``f`` at 0 by Ridders' extrapolated central differences.

    ``f(h)`` returns ``(value, realized_h)``: the step actually taken after rounding the
    displaced argument (e.g. ``(p + h) - p``), which the difference quotient divides by.
    Returns ``(estimate, error_estimate)`` (Numerical Recipes, ``dfridr``).
    """

    def central(h):
        (fp, hp), (fm, hm) = f(h), f(-h)
        return (fp - fm) / (hp - hm)

    a = np.zeros((ntab, ntab))
    hh = h0
    a[0, 0] = central(hh)
    err, ans = np.inf, a[0, 0]
    for i in range(1, ntab):
        hh /= con
        a[0, i] = central(hh)
        fac = con * con
        for j in range(1, i + 1):
            a[j, i] = (a[j - 1, i] * fac - a[j - 1, i - 1]) / (fac - 1)
            fac *= con * con
            errt = max(abs(a[j, i] - a[j - 1, i]), abs(a[j, i] - a[j - 1, i - 1]))
            if errt <= err:
                err, ans = errt, a[j, i]
        if abs(a[i, i] - a[i - 1, i - 1]) >= 2 * err:
            break
    return ans, err


def gradient_wrt_b(energy, R_WB, p_WB, h_rot, h_lin):
    """Gradient of ``energy(R_WB, p_WB)`` w.r.t. a world-frame twist of B about ``p_WB``.

    Component ``i < 3`` rotates B by ``exp(h e_i^)`` on the left; ``i >= 3`` translates it.
    """
    g = np.zeros(6)
    for i in range(6):
        e = np.zeros(3)
        e[i % 3] = 1.0
        if i < 3:
            g[i] = ridders(lambda h, e=e: (energy(rot_exp(h * e) @ R_WB, p_WB), h), h_rot)[0]
        else:
            k = i - 3

            def f(h, e=e, k=k):
                p = p_WB + h * e
                return energy(R_WB, p), p[k] - p_WB[k]

            g[i] = ridders(f, h_lin)[0]
    return g


def hat(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def lambda_tilde(q):
    """The 6x8 map of the paper's eq. 116 for a unit dual quaternion ``q = (sigma, xi, s', x')``.

    Columns ``(sigma, xi, s', x')``; the wrench of B on the element is ``1/2 Lambda~ grad U``.
    """
    s, xi, sd, xd = q[0], q[1:4], q[4], q[5:]
    L = np.zeros((6, 8))
    L[:3, 0], L[:3, 1:4], L[:3, 4], L[:3, 5:] = -xi, s * np.eye(3) - hat(xi), -xd, sd * np.eye(3) - hat(xd)
    L[3:, 4], L[3:, 5:] = -xi, s * np.eye(3) - hat(xi)
    return L


def c_output(capfd):
    """What C code printed (MuJoCo's warnings go to stderr), once its stdio buffers are flushed."""
    import ctypes

    ctypes.CDLL(None).fflush(None)
    captured = capfd.readouterr()
    return captured.out + captured.err
