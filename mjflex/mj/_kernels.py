"""Compiled per-step loop of the passive-force provider (numba; reads MuJoCo arrays, no bindings).

:func:`flexure_loop` evaluates every element of one model from the arrays of one ``mjData``
(``site_xpos``, ``site_xmat``, ``cvel``, ...) with the core kernel and, depending on ``mode``,
adds the generalized forces to ``qfrc_passive`` and/or writes wrenches, energies or powers.
:func:`dispatch` is the same loop reached from raw ``mjModel*`` / ``mjData*`` addresses through
the registry that :mod:`mjflex.mj._callback` maintains; it runs inside ``mj_passive`` without
the GIL or the Python bindings.

Element tables (built once by :mod:`._tables`), their columns named once below (``columns``):

* ``ints`` (n, NI) int64, ``INT_COLUMNS``: site and body ids, method, switches, fast-path dof
  address of each body (-1 when the body is not a free-jointed child of the world), and the
  range of its dof chain in ``chain``;
* ``floats`` (n, NF) float64, ``FLOAT_COLUMNS``: K and B (row-major 6x6), the rest offset
  ``X_ab0`` (R, p) of frame b seen from frame a at ``qpos0`` (round-off of the model file,
  absorbed so that the reference configuration is exactly unstressed), and the inverse mass
  and inertia used by the divergence check;
* ``exps`` (M, 8) int64 and ``coefs`` (M,) float64: the polynomial terms of all elements (rows
  ``terms_lo:terms_hi`` of ``ints`` belong to an element; twist rows use the first 6 columns).
  Their work arrays live on the stack of :func:`flexure_loop` (``stack_doubles``), so
  evaluating them allocates nothing, in any thread.

The registry that :func:`dispatch` reads (``HEADER_WORDS``, ``SLOT_WORDS``) is described in
:mod:`mjflex.mj._callback`, with the rules the native callback follows.
"""

import math

import numpy as np
from llvmlite import ir
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from ..core._kernels import (
    _cross,
    _lin,
    load3,
    load9,
    load36,
    relative_position,
    relative_quat,
    twist_from_quat_pos,
)
from ..core._poly_kernels import spatial_potential_terms, spatial_wrench_terms
from ..core.polynomial import MAX_EXPONENT


def columns(*fields: tuple[str, int]) -> tuple[dict[str, int], int]:
    """Start column of each ``(name, width)`` field laid out one after the other, and the total width.

    The one definition of the provider's tables and registry words: adding a field changes
    only its list below.
    """
    start, at = {}, 0
    for name, width in fields:
        start[name] = at
        at += width
    return start, at


#: Columns of ``ints`` (n, NI): site and body ids of the element's frames a and b, method
#: code, run-time switches, whether a rest offset applies, free-joint dof address of each
#: body (-1: not a free-jointed child of the world) and the range of its dof chain in ``chain``.
INT_COLUMNS, NI = columns(
    ("site_a", 1), ("site_b", 1), ("body_a", 1), ("body_b", 1), ("method", 1), ("enabled", 1), ("viscous", 1),
    ("offset", 1), ("free_a", 1), ("free_b", 1), ("chain_a0", 1), ("chain_a1", 1), ("chain_b0", 1), ("chain_b1", 1),
    ("terms_lo", 1), ("terms_hi", 1), ("terms_top", 1),
)  # fmt: skip
#: Columns of ``floats`` (n, NF): K and B (row-major 6x6), the rest offset ``X_ab0`` (R row-major,
#: p), and the largest inverse mass [1/kg] and inverse principal inertia [1/(kg m^2)] of the
#: element's (non-world) bodies, which turn its wrench into the acceleration it alone would
#: cause (the divergence check, see ``ACCEL_LIMIT``).
FLOAT_COLUMNS, NF = columns(("K", 36), ("B", 36), ("R0", 9), ("p0", 3), ("inv_mass", 1), ("inv_inertia", 1))
_I, _F = INT_COLUMNS, FLOAT_COLUMNS
SITE_A, SITE_B, BODY_A, BODY_B = _I["site_a"], _I["site_b"], _I["body_a"], _I["body_b"]
METHOD, ENABLED, VISCOUS, OFFSET = _I["method"], _I["enabled"], _I["viscous"], _I["offset"]
FREE_A, FREE_B = _I["free_a"], _I["free_b"]
CHAIN_A0, CHAIN_A1, CHAIN_B0, CHAIN_B1 = _I["chain_a0"], _I["chain_a1"], _I["chain_b0"], _I["chain_b1"]
TERMS_LO, TERMS_HI, TERMS_TOP = _I["terms_lo"], _I["terms_hi"], _I["terms_top"]
#: Width of the terms' exponent table and of the powers work array (coordinates, powers 0..MAX_EXPONENT).
TERM_COLUMNS, POWER_COLUMNS = 8, MAX_EXPONENT + 1
_PW_SIZE, _GRAD_SIZE = TERM_COLUMNS * POWER_COLUMNS, 2 * TERM_COLUMNS  # stack buffers of flexure_loop
K_AT, B_AT, R0_AT, P0_AT, INV_MASS, INV_INERTIA = (
    _F["K"],
    _F["B"],
    _F["R0"],
    _F["p0"],
    _F["inv_mass"],
    _F["inv_inertia"],
)

#: An element whose wrench alone would accelerate one of its bodies beyond this [m/s^2 or
#: rad/s^2] counts as diverging: MuJoCo's ``mjMAXVAL``, the bound beyond which MuJoCo itself
#: declares ``qpos``/``qvel``/``qacc`` bad and resets. Checking it here names the element
#: before MuJoCo's own check resets the state.
ACCEL_LIMIT = 1e10

APPLY, WRENCH, ENERGY, POWER, COORDS = 1, 2, 4, 8, 16

# registry (int64 words): a header, then one slot per served model. A slot is in use when its
# "model" word is non-zero; slots never move, and only the first H_USED can be in use.
HEADER_WORDS, HEADER = columns(
    ("capacity", 1), ("spring_bit", 1), ("damper_bit", 1), ("disableflags", 1), ("site_xpos", 1), ("site_xmat", 1),
    ("xpos", 1), ("xmat", 1), ("cvel", 1), ("subtree_com", 1), ("cdof", 1), ("qfrc_passive", 1), ("used", 1),
    ("time", 1), ("timestep", 1), ("autoreset_bit", 1),
)  # fmt: skip
_H = HEADER_WORDS
H_CAPACITY, H_SPRING_BIT, H_DAMPER_BIT, H_AUTORESET_BIT = (
    _H["capacity"],
    _H["spring_bit"],
    _H["damper_bit"],
    _H["autoreset_bit"],
)
H_DISABLEFLAGS, H_TIME, H_TIMESTEP, H_USED = _H["disableflags"], _H["time"], _H["timestep"], _H["used"]
H_SITE_XPOS, H_SITE_XMAT, H_XPOS, H_XMAT = _H["site_xpos"], _H["site_xmat"], _H["xpos"], _H["xmat"]
H_CVEL, H_SUBTREE_COM, H_CDOF, H_QFRC = _H["cvel"], _H["subtree_com"], _H["cdof"], _H["qfrc_passive"]
SLOT_WORDS, SLOT = columns(
    ("model", 1), ("n", 1), ("ints", 1), ("floats", 1), ("chain", 1), ("nchain", 1), ("rootid", 1), ("nsite", 1),
    ("nbody", 1), ("nv", 1), ("messages", 1), ("exps", 1), ("coefs", 1), ("nterms", 1),
)  # fmt: skip
_S = SLOT_WORDS
S_MODEL, S_N, S_INTS, S_FLOATS, S_CHAIN, S_NCHAIN = (
    _S["model"],
    _S["n"],
    _S["ints"],
    _S["floats"],
    _S["chain"],
    _S["nchain"],
)
S_ROOTID, S_NSITE, S_NBODY, S_NV, S_MESSAGES = _S["rootid"], _S["nsite"], _S["nbody"], _S["nv"], _S["messages"]
S_EXPS, S_COEFS, S_NTERMS = _S["exps"], _S["coefs"], _S["nterms"]

_JIT = {"cache": True, "error_model": "numpy", "fastmath": {"contract"}}
_ZERO3 = (0.0, 0.0, 0.0)
_ZERO36 = (0.0,) * 36


@intrinsic
def voidptr_from_int(typingctx, addr):
    """``(void*) addr``."""

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return types.voidptr(types.int64), codegen


@intrinsic
def int_from_voidptr(typingctx, ptr):
    """``(int64) ptr``."""

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], cgutils.intp_t)

    return types.int64(types.voidptr), codegen


@intrinsic
def stack_doubles(typingctx, n):
    """Pointer to ``n`` (a compile-time constant) float64 on the caller's stack, allocated once per call.

    Code generated inline in the calling function: the buffer lives as long as that call, in the
    calling thread, and costs no allocation.
    """
    if not isinstance(n, types.IntegerLiteral):
        return None
    size = n.literal_value

    def codegen(context, builder, signature, args):
        return builder.bitcast(cgutils.alloca_once(builder, ir.DoubleType(), size=size), cgutils.voidptr_t)

    return types.voidptr(n), codegen


@njit(**_JIT)
def _frame_b(ints, floats, e, R, p):
    """Pose of frame b, corrected by the rest offset: ``X_Wb* = X_Wb X_ab0^-1``."""
    if ints[e, OFFSET] == 0:
        return R, p
    R0 = load9(floats, e, R0_AT)
    Rs = (  # R_b* = R_b R0^T
        R[0] * R0[0] + R[1] * R0[1] + R[2] * R0[2], R[0] * R0[3] + R[1] * R0[4] + R[2] * R0[5],
        R[0] * R0[6] + R[1] * R0[7] + R[2] * R0[8], R[3] * R0[0] + R[4] * R0[1] + R[5] * R0[2],
        R[3] * R0[3] + R[4] * R0[4] + R[5] * R0[5], R[3] * R0[6] + R[4] * R0[7] + R[5] * R0[8],
        R[6] * R0[0] + R[7] * R0[1] + R[8] * R0[2], R[6] * R0[3] + R[7] * R0[4] + R[8] * R0[5],
        R[6] * R0[6] + R[7] * R0[7] + R[8] * R0[8],
    )  # fmt: skip
    p0 = load3(floats, e, P0_AT)
    q = (
        Rs[0] * p0[0] + Rs[1] * p0[1] + Rs[2] * p0[2],
        Rs[3] * p0[0] + Rs[4] * p0[1] + Rs[5] * p0[2],
        Rs[6] * p0[0] + Rs[7] * p0[1] + Rs[8] * p0[2],
    )
    return Rs, (p[0] - q[0], p[1] - q[1], p[2] - q[2])


@njit(**_JIT)
def _point_velocity(cvel, subtree_com, rootid, body, p):
    """World angular velocity of ``body`` and linear velocity of its point ``p``."""
    w = (cvel[body, 0], cvel[body, 1], cvel[body, 2])
    c = load3(subtree_com, rootid[body])
    v = (cvel[body, 3], cvel[body, 4], cvel[body, 5])
    return w, _lin(1.0, v, 1.0, _cross(w, (p[0] - c[0], p[1] - c[1], p[2] - c[2])))


@njit(**_JIT)
def _apply(qfrc, body, free_adr, chain, c0, c1, m, f, p, xpos, xmat, cdof, subtree_com, rootid, sign):
    """Add ``sign * (m about p, f)`` on ``body`` to generalized forces (``J^T`` of the wrench)."""
    if free_adr >= 0:
        # free joint: dofs are the world velocity of the body origin, then the body-frame angular velocity
        o = load3(xpos, body)
        mo = _lin(1.0, m, 1.0, _cross((p[0] - o[0], p[1] - o[1], p[2] - o[2]), f))
        for k in range(3):
            qfrc[free_adr + k] += sign * f[k]
            qfrc[free_adr + 3 + k] += sign * (
                xmat[body, k] * mo[0] + xmat[body, 3 + k] * mo[1] + xmat[body, 6 + k] * mo[2]
            )
        return
    c = load3(subtree_com, rootid[body])
    mc = _lin(1.0, m, 1.0, _cross((p[0] - c[0], p[1] - c[1], p[2] - c[2]), f))
    for k in range(c0, c1):
        j = chain[k]
        qfrc[j] += sign * (
            cdof[j, 0] * mc[0] + cdof[j, 1] * mc[1] + cdof[j, 2] * mc[2]
            + cdof[j, 3] * f[0] + cdof[j, 4] * f[1] + cdof[j, 5] * f[2]
        )  # fmt: skip


@njit(**_JIT)
def flexure_loop(
    mode, ints, floats, chain, rootid, exps, coefs, site_xpos, site_xmat, xpos, xmat, cvel, subtree_com, cdof,
    spring_on, damper_on, accel_limit, qfrc, out6, out1,
):  # fmt: skip
    """Evaluate all elements; returns -1, or the index of the first diverging element.

    An element diverges when its wrench or power is not finite, or when its wrench alone
    would accelerate one of its bodies beyond ``accel_limit`` (``ACCEL_LIMIT`` in the callback,
    ``inf`` for the queries of a state).

    ``mode`` is a bit set: APPLY adds to ``qfrc``; WRENCH writes ``out6[e]`` = wrench on body B
    ``[moment about frame b; force]`` (world); ENERGY writes ``out1[e]`` = elastic energy;
    POWER writes ``out1[e]`` = dissipated power; COORDS writes ``out6[e]`` = the element's
    finite twist. Disabled elements give zeros. Polynomial terms (rows ``terms_lo:terms_hi`` of
    ``exps``, ``coefs``) are elastic: switched off with the springs like ``K``.
    """
    pw = carray(stack_doubles(_PW_SIZE), (TERM_COLUMNS, POWER_COLUMNS), np.float64)
    grad = carray(stack_doubles(_GRAD_SIZE), (_GRAD_SIZE,), np.float64)
    for e in range(ints.shape[0]):
        if ints[e, ENABLED] == 0:
            if mode & (WRENCH | COORDS):
                out6[e, :] = 0.0
            if mode & (ENERGY | POWER):
                out1[e] = 0.0
            continue
        Ra, pa = load9(site_xmat, ints[e, SITE_A]), load3(site_xpos, ints[e, SITE_A])
        Rb, pb = _frame_b(ints, floats, e, load9(site_xmat, ints[e, SITE_B]), load3(site_xpos, ints[e, SITE_B]))
        method = ints[e, METHOD]
        if mode & COORDS:
            w, x, y, z = relative_quat(Ra, Rb)
            tau, t, _ = twist_from_quat_pos(w, x, y, z, relative_position(Ra, pa, pb))
            out6[e, 0], out6[e, 1], out6[e, 2], out6[e, 3], out6[e, 4], out6[e, 5] = tau + t
            continue
        K = load36(floats, e, K_AT) if spring_on else _ZERO36
        lo, hi = ints[e, TERMS_LO], ints[e, TERMS_HI] if spring_on else ints[e, TERMS_LO]
        top = ints[e, TERMS_TOP]
        if mode & ENERGY:
            out1[e] = spatial_potential_terms(method, Ra, pa, Rb, pb, K, exps, coefs, lo, hi, top, pw, grad)
            continue
        viscous = damper_on and ints[e, VISCOUS] != 0
        wa, va, wb, vb = _ZERO3, _ZERO3, _ZERO3, _ZERO3
        if viscous:
            wa, va = _point_velocity(cvel, subtree_com, rootid, ints[e, BODY_A], pa)
            wb, vb = _point_velocity(cvel, subtree_com, rootid, ints[e, BODY_B], pb)
        B = load36(floats, e, B_AT) if viscous else _ZERO36
        m, f, power = spatial_wrench_terms(method, Ra, pa, Rb, pb, K, B, viscous, wa, va, wb, vb,
                                           exps, coefs, lo, hi, top, pw, grad)  # fmt: skip
        if not math.isfinite(m[0] + m[1] + m[2] + f[0] + f[1] + f[2] + power):
            return e
        if (
            max(abs(f[0]), abs(f[1]), abs(f[2])) * floats[e, INV_MASS] > accel_limit
            or max(abs(m[0]), abs(m[1]), abs(m[2])) * floats[e, INV_INERTIA] > accel_limit
        ):
            return e
        if mode & WRENCH:
            out6[e, 0], out6[e, 1], out6[e, 2], out6[e, 3], out6[e, 4], out6[e, 5] = m[0], m[1], m[2], f[0], f[1], f[2]
        if mode & POWER:
            out1[e] = power
        if mode & APPLY:
            _apply(qfrc, ints[e, BODY_B], ints[e, FREE_B], chain, ints[e, CHAIN_B0], ints[e, CHAIN_B1],
                   m, f, pb, xpos, xmat, cdof, subtree_com, rootid, 1.0)  # fmt: skip
            _apply(qfrc, ints[e, BODY_A], ints[e, FREE_A], chain, ints[e, CHAIN_A0], ints[e, CHAIN_A1],
                   m, f, pb, xpos, xmat, cdof, subtree_com, rootid, -1.0)  # fmt: skip
    return -1


# --------------------------------------------------------------------------- raw-pointer access


@njit(**_JIT)
def _word(addr):
    return carray(voidptr_from_int(addr), (1,), np.int64)[0]


@njit(**_JIT)
def _field(d_addr, offset, rows, cols):
    """The (rows, cols) float64 array that the pointer at ``d_addr + offset`` points to."""
    return carray(voidptr_from_int(_word(d_addr + offset)), (rows, cols), np.float64)


@njit(**_JIT)
def dispatch(m_addr, d_addr, reg_addr):
    """Apply the elements registered for model ``m_addr`` to data ``d_addr``.

    Returns 0, or the address of the error message (a printf format taking the time) of the
    first diverging element; ``qfrc_passive`` is then filled with NaN so that MuJoCo's own
    divergence handling (warning, auto-reset) sees it too, and the callback reports the message.
    Allocates nothing and raises nothing: everything it reads was validated at installation.
    """
    capacity = _word(reg_addr + 8 * H_CAPACITY)
    reg = carray(voidptr_from_int(reg_addr), (HEADER + SLOT * capacity,), np.int64)
    for s in range(reg[H_USED]):
        at = HEADER + SLOT * s
        if reg[at + S_MODEL] != m_addr:
            continue
        flags = carray(voidptr_from_int(m_addr + reg[H_DISABLEFLAGS]), (1,), np.int32)[0]
        n, nsite, nbody, nv = reg[at + S_N], reg[at + S_NSITE], reg[at + S_NBODY], reg[at + S_NV]
        ints = carray(voidptr_from_int(reg[at + S_INTS]), (n, NI), np.int64)
        floats = carray(voidptr_from_int(reg[at + S_FLOATS]), (n, NF), np.float64)
        chain = carray(voidptr_from_int(reg[at + S_CHAIN]), (reg[at + S_NCHAIN],), np.int64)
        rootid = carray(voidptr_from_int(reg[at + S_ROOTID]), (nbody,), np.int64)
        exps = carray(voidptr_from_int(reg[at + S_EXPS]), (reg[at + S_NTERMS], TERM_COLUMNS), np.int64)
        coefs = carray(voidptr_from_int(reg[at + S_COEFS]), (reg[at + S_NTERMS],), np.float64)
        qfrc_ptr = voidptr_from_int(_word(d_addr + reg[H_QFRC]))
        qfrc = carray(qfrc_ptr, (nv,), np.float64)
        unused6, unused1 = carray(qfrc_ptr, (0, 6), np.float64), qfrc[:0]  # empty outputs, no allocation
        status = flexure_loop(
            APPLY, ints, floats, chain, rootid, exps, coefs,
            _field(d_addr, reg[H_SITE_XPOS], nsite, 3), _field(d_addr, reg[H_SITE_XMAT], nsite, 9),
            _field(d_addr, reg[H_XPOS], nbody, 3), _field(d_addr, reg[H_XMAT], nbody, 9),
            _field(d_addr, reg[H_CVEL], nbody, 6), _field(d_addr, reg[H_SUBTREE_COM], nbody, 3),
            _field(d_addr, reg[H_CDOF], nv, 6),
            (flags & reg[H_SPRING_BIT]) == 0, (flags & reg[H_DAMPER_BIT]) == 0, ACCEL_LIMIT,
            qfrc, unused6, unused1,
        )  # fmt: skip
        if status >= 0:
            qfrc[:] = np.nan  # the state diverged: make sure MuJoCo's own checks see it too
            return carray(voidptr_from_int(reg[at + S_MESSAGES]), (n,), np.int64)[status]
        return 0
    return 0


@njit(**_JIT)
def _double(addr):
    return carray(voidptr_from_int(addr), (1,), np.float64)[0]


@njit(**_JIT)
def report_context(m_addr, d_addr, reg_addr):
    """``(time, autoreset on, step)`` of data ``d_addr`` of model ``m_addr``, for a divergence report."""
    time = _double(d_addr + _word(reg_addr + 8 * H_TIME))
    timestep = _double(m_addr + _word(reg_addr + 8 * H_TIMESTEP))
    flags = carray(voidptr_from_int(m_addr + _word(reg_addr + 8 * H_DISABLEFLAGS)), (1,), np.int32)[0]
    step = time / timestep if timestep > 0.0 else 0.0
    return time, (flags & _word(reg_addr + 8 * H_AUTORESET_BIT)) == 0, step
