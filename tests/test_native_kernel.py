"""The native kernel's own guarantees (mjflex/native/flexure_kernel.h, evaluate.h).

* The functions of the rotation angle: their small-angle series (coefficients exact, re-derived here
  from Bernoulli numbers) and every branch against mpmath, on both sides of each threshold.
* Elements are evaluated several at once, one per vector lane, and the lane count is chosen per CPU
  (2 with SSE2, 4 with AVX): an element's numbers must not depend on its neighbours nor on the lane
  count (bit for bit), and the generalized forces must be each wrench applied at frame b (mj_applyFT
  of the core's wrench, an independent path), for every kind of element and joint.
"""

import ctypes
import os
import subprocess
import sys
from fractions import Fraction
from math import comb, factorial

import mpmath
import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from mjflex.native import library as _native
from tests.conftest import c_compiler
from tests.helpers import random_spd
from tests.models import hinge_chain_spec
from tests.plugin_models import assert_not_diverged

# c(a) = (1 - (a/2) cot(a/2)) / a^2 and g(a) = c'(a) / a: the twist's maps (EQUATIONS.md, eq. 44)
SMALL = 2 * np.arctan(0.1)  # below it (n < w / 10) s, c, g are series in rho = tan^2(a/2)


def _bernoulli(n):
    B = [Fraction(0)] * (n + 1)
    B[0] = Fraction(1)
    for m in range(1, n + 1):
        B[m] = -sum(comb(m + 1, k) * B[k] for k in range(m)) / (m + 1)
    return B


def _series_in_rho(terms):
    """Exact Taylor coefficients in rho = r^2 of atan(r)/r, c(2 atan r) and g(2 atan r)."""

    def mul(a, b):
        out = [Fraction(0)] * terms
        for i, x in enumerate(a):
            for j, y in enumerate(b[: terms - i]):
                out[i + j] += x * y
        return out

    B = _bernoulli(2 * terms + 4)
    c = [(-1) ** k * B[2 * k + 2] / factorial(2 * k + 2) for k in range(terms + 1)]  # in a^2: 1/12 + a^2/720 ...
    g = [2 * (k + 1) * c[k + 1] for k in range(terms)]
    atan = [Fraction((-1) ** k, 2 * k + 1) for k in range(terms)]
    a2 = [Fraction(0)] + [4 * x for x in mul(atan, atan)[: terms - 1]]  # a^2 = 4 rho (atan(r)/r)^2

    def compose(coefs):
        out, power = [Fraction(0)] * terms, [Fraction(1)] + [Fraction(0)] * (terms - 1)
        for k in range(terms):
            out = [o + coefs[k] * p for o, p in zip(out, power, strict=True)]
            power = mul(power, a2)
        return out

    return atan, compose(c), compose(g)


def test_small_angle_series_are_the_exact_taylor_coefficients():
    native = _native.lib()
    atan, c, g = _series_in_rho(10)
    odd = [(-1) ** k * x for k, x in enumerate(atan)]  # the C table: 1 / (2k + 1), evaluated at -rho
    for name, exact, n in (("mjfx_odd_inv", odd, 9), ("mjfx_small_c", c, 8), ("mjfx_small_g", g, 8)):
        table = list((ctypes.c_double * n).in_dll(native, name))
        assert table == [float(x) for x in exact[:n]], name
    # what is left out at the threshold (rho = 0.01; alternating series: the first term left out bounds it) is
    # far below round-off
    assert abs(float(c[8])) * 0.01**8 < 1e-17 * float(c[0]) and abs(float(g[8])) * 0.01**8 < 1e-17 * float(g[0])
    assert abs(float(atan[9])) * 0.01**9 < 1e-17
    # the per-lane series in a^2, up to 2.2 rad: the Taylor coefficients of c and g (positive: the first term left
    # out, 1e-17 of the first, and the geometric tail after it stay below round-off)
    B = _bernoulli(50)
    c_a = [(-1) ** k * B[2 * k + 2] / factorial(2 * k + 2) for k in range(22)]
    g_a = [2 * (k + 1) * c_a[k + 1] for k in range(21)]
    got_c, got_g = np.zeros(20), np.zeros(20)
    assert native.mjfx_series_coefficients(got_c.ctypes.data, got_g.ctypes.data, 20) == 20
    assert list(got_c) == [float(x) for x in c_a[:20]] and list(got_g) == [float(x) for x in g_a[:20]]
    assert float(c_a[20]) * 2.2**40 < 1e-18 * float(c_a[0]) and float(g_a[20]) * 2.2**40 < 2e-17 * float(g_a[0])


def _reference(n2, w):
    """s = a / n, c(a), g(a) at the exact angle of (n2, w), to 40 digits (1 - h cot h ~ h^2 / 3 and the
    derivative's difference ~ h^4 cancel: the working precision grows with 1 / a)."""
    if n2 == 0:
        return 2 / mpmath.mpf(w), mpmath.mpf(1) / 12, mpmath.mpf(1) / 360
    with mpmath.workdps(50 + int(-4 * min(0.0, np.log10(n2) / 2))):
        n = mpmath.sqrt(mpmath.mpf(n2))
        a = 2 * mpmath.atan2(n, mpmath.mpf(w))
        h = a / 2
        c = (1 - h * mpmath.cot(h)) / a**2
        dc = -(mpmath.cot(h) - h * mpmath.csc(h) ** 2) / (2 * a**2) - 2 * (1 - h * mpmath.cot(h)) / a**3
        return a / n, c, dc / a


# angles [rad]: zero and tiny, the lanes' series up to and across its threshold (2 atan 0.1), the per-lane
# series in a^2 up to and across 2.2 rad, the closed forms up to a half turn
ANGLES = [0.0, 1e-150, 1e-9, 1e-4, 0.05, SMALL * (1 - 1e-9), SMALL, SMALL * (1 + 1e-9), 0.25, 0.999, 1.0,
          1.001, 1.6, 2.2 - 1e-9, 2.2, 2.2 + 1e-9, 2.5, 3.0, np.pi - 1e-6]  # fmt: skip


def test_angle_functions_match_mpmath_on_every_branch():
    """The named angles and 300 more spread over (0, pi) (a misplaced threshold leaves a series too short
    somewhere), with the branch point itself and its neighbouring doubles."""
    rng = np.random.default_rng(12)
    cases = []
    for angle in [*ANGLES, *np.sort(rng.uniform(0, np.pi, 300))]:
        axis = rng.normal(size=3)
        q = np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis / np.linalg.norm(axis)]
        cases.append((float(q[1:] @ q[1:]), float(q[0]), angle))
    w = 1.0 / np.sqrt(1.01)  # at the branch point n2 = w^2 / 100
    cases += [(np.nextafter(0.01 * (w * w), s), w, SMALL) for s in (0.0, 1.0)] + [(0.01 * (w * w), w, SMALL)]
    for n2, w, angle in cases:
        out = [ctypes.c_double() for _ in range(3)]
        _native.lib().mjfx_angle_coefs(n2, w, *(ctypes.byref(o) for o in out))
        for name, got, ref in zip("scg", (o.value for o in out), _reference(n2, w), strict=True):
            # the closed forms above 2.2 rad cancel a little: g = (h cot h + h^2 csc^2 h - 2) / (16 h^4)
            rtol = 1e-14 if angle >= 2.2 else 2e-15
            assert abs(got - float(ref)) <= rtol * abs(float(ref)), (name, angle, got, float(ref))


# ------------------------------------------------------------------------ lanes and groups


def mixed_model():
    """Nine free boxes and the world joined by 13 elements of every kind, in an order that makes groups of 1 to 5
    consecutive elements of one kind: twist and dual quaternion, diagonal and full K and B, no damping,
    polynomial terms, end stops (engaged at the states of _moved), grounded, disabled. Saved and reloaded, so that
    6-digit site poses leave rest offsets."""
    rng = np.random.default_rng(8)
    spec = mujoco.MjSpec()
    spec.modelname = "mixed"
    spec.option.gravity = [0, 0, 0]
    for i in range(9):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.05 * i, 0.01 * np.sin(i), 0],
                                       quat=Rotation.random(random_state=rng).as_quat(scalar_first=True))  # fmt: skip
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.005, 0.01], density=2700, contype=0,
                      conaffinity=0)  # fmt: skip
    poses = mjflex.reference_body_poses(spec)
    diag = np.diag([0.6, 0.8, 0.5, 3e3, 4e3, 2e3])
    full = random_spd(rng, cond=1e3, scales=[1, 1, 1, 60, 60, 60])
    terms = mjflex.PolynomialTerms("twist", mjflex.polynomial_basis("twist", 3),
                                   0.3 * rng.normal(size=len(mjflex.polynomial_basis("twist", 3))))  # fmt: skip

    def stops(i):  # a little off rest, on every coordinate (some one-sided), as stiff as K (stable at the step),
        s = 1.0 + 0.1 * i  # and different in each element (lanes must not mix)
        return mjflex.Stops(
            lower=[-0.02 * s, -0.03, None, -0.002, -0.003 * s, -0.001],
            upper=[0.02, None, 0.01 * s, 0.002 * s, None, 0.004],
            stiffness=s * diag.diagonal(),
        )

    layout = [  # (body a, body b, method, K, B, extra)
        *[(i, i + 1, "twist", diag, 1e-3 * diag, {"stops": stops(i)} if i < 3 else {}) for i in range(5)],
        (5, 6, "dualquat", full, 2e-3 * full, {}),
        (6, 7, "dualquat", full, None, {"stops": stops(6)}),
        (7, 8, "twist", full, 1e-3 * full, {"terms": terms, "stops": stops(7)}),
        (-1, 0, "twist", diag, 1e-3 * diag, {}),
        (0, 2, "twist", diag, 1e-3 * diag, {}),
        (1, 3, "dualquat", diag, 1e-3 * diag, {}),
        (2, 4, "twist", diag, 1e-3 * diag, {"enabled": False}),
        (4, 8, "twist", diag, 1e-3 * diag, {}),
    ]
    for e, (a, b, method, K, B, extra) in enumerate(layout):
        pa = poses[0][a + 1] if a >= 0 else np.zeros(3)
        mjflex.add_flexure(spec, f"e{e}", f"b{a}" if a >= 0 else "world", f"b{b}", pos=0.5 * (pa + poses[0][b + 1]),
                           quat=Rotation.random(random_state=rng).as_quat(scalar_first=True), K=K, B=B,
                           method=method, poses=poses, kind="record", **extra)  # fmt: skip
    return mujoco.MjModel.from_xml_string(spec.to_xml())


def _moved(model, rng, angle):
    """A state with each free body turned by up to ``angle`` and moving."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    for j in range(model.njnt):
        adr = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            data.qpos[adr : adr + 3] += 0.005 * rng.normal(size=3)
            turn = Rotation.from_rotvec(rng.uniform(0, angle) * Rotation.random(random_state=rng).as_rotvec() / np.pi)
            q = turn * Rotation.from_quat(data.qpos[adr + 3 : adr + 7], scalar_first=True)
            data.qpos[adr + 3 : adr + 7] = q.as_quat(scalar_first=True)
    data.qvel[:] = rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)
    return data


@pytest.fixture
def lanes():
    """Set the native lane count for a test (restored after)."""
    native = _native.lib()
    yield lambda n: native.mjfx_set_lanes(n)
    native.mjfx_set_lanes(0)


EVERY = slice(None)


def _evaluate(flex, data, mode, sl=EVERY, qfrc=None):
    t = flex.element_table
    n = len(flex)
    out6, out1 = np.zeros((n, 6)), np.zeros(n)
    rows = t.elements[:n][sl]
    _native.evaluate(flex.model, data, rows, t.chain, t.exps, t.coefs, mode, qfrc=qfrc, out6=out6, out1=out1)
    return out6[: len(rows)], out1[: len(rows)]


def test_lane_counts_give_the_same_bits(lanes):
    """Every lane count the CPU offers moves ARCADE and the mixed model identically, bit for bit."""
    native = _native.lib()
    counts = [n for n in (1, 2, 4) if native.mjfx_lanes_available(n)]
    assert counts and native.mjfx_lanes() == max(counts)  # the widest by default
    if 4 not in counts:
        assert lanes(4) == -1  # refused, the base loop stays
    arcade = mujoco.MjModel.from_xml_path("models/arcade.xml")
    for model in (arcade, mixed_model()):
        flex = mjflex.Flexures(model)
        if model is arcade:  # its keyframe (the deflected guide), moving (every body turned 0.3 rad diverges)
            data0 = mujoco.MjData(model)
            mujoco.mj_resetDataKeyframe(model, data0, 0)
            data0.qvel[:] = 0.1 * np.random.default_rng(3).normal(size=model.nv)
        else:  # far from rest, stops engaged, accelerations near MuJoCo's limit of 1e10: 2e-6 s steps diverge
            model.opt.timestep = 5e-7
            data0 = _moved(model, np.random.default_rng(3), 0.3)
        runs = []
        for n in counts:
            assert lanes(n) >= 0 and _native.lanes() == n
            data = mujoco.MjData(model)
            data.qpos[:], data.qvel[:] = data0.qpos, data0.qvel
            with flex:
                for _ in range(50):
                    mujoco.mj_step(model, data)
            assert_not_diverged(data, f"model with nv {model.nv}, {n} lanes")
            runs.append((data.qpos.copy(), data.qvel.copy(), _evaluate(flex, data0, _native.WRENCH)[0]))
        for run in runs[1:]:
            for got, first in zip(run, runs[0], strict=True):
                assert np.array_equal(got, first)


@pytest.mark.parametrize("angle", [1e-3, 0.3, 3.0])
def test_an_element_gives_the_same_bits_alone_and_beside_any_other(lanes, angle):
    """Evaluated one by one, in the groups the table makes, or in the other lane count: the same bits for the
    wrench, power and energy of each element and the generalized forces of all (added in element order)."""
    model = mixed_model()
    flex = mjflex.Flexures(model)
    data = _moved(model, np.random.default_rng(5), angle)
    native = _native.lib()
    for n in [n for n in (1, 2, 4) if native.mjfx_lanes_available(n)]:
        lanes(n)
        together = [_evaluate(flex, data, mode) for mode in (_native.WRENCH, _native.POWER, _native.ENERGY)]
        qfrc_together = np.zeros(model.nv)
        _evaluate(flex, data, _native.APPLY, qfrc=qfrc_together)
        qfrc_alone = np.zeros(model.nv)
        for e in range(len(flex)):
            alone = [_evaluate(flex, data, mode, slice(e, e + 1)) for mode in (_native.WRENCH, _native.POWER,
                                                                                _native.ENERGY)]  # fmt: skip
            assert np.array_equal(alone[0][0][0], together[0][0][e])
            assert alone[1][1][0] == together[1][1][e] and alone[2][1][0] == together[2][1][e]
            _evaluate(flex, data, _native.APPLY, slice(e, e + 1), qfrc=qfrc_alone)
        assert np.array_equal(qfrc_alone, qfrc_together)
        assert np.array_equal(qfrc_together, flex.generalized_forces(data))
        # the divergence scan: the element whose wrench alone accelerates a body most (largest force component
        # times the largest inverse mass, or moment times inverse inertia)
        rows, W = flex.element_table.elements[: len(flex)], together[0][0]
        accel = np.maximum(np.abs(W[:, 3:]).max(1) * rows["inv_mass"], np.abs(W[:, :3]).max(1) * rows["inv_inertia"])
        scan, t = _native.Scan(), flex.element_table
        native.mjfx_evaluate(model._address, data._address, rows.ctypes.data, len(flex), t.chain.ctypes.data,
                             t.exps.ctypes.data, t.coefs.ctypes.data, _native.WRENCH, None,
                             np.zeros((len(flex), 6)).ctypes.data, None, ctypes.byref(scan))  # fmt: skip
        assert (scan.nonfinite, scan.largest, scan.accel) == (-1, int(np.argmax(accel)), accel.max())


def _core_generalized_forces(model, data, flex):
    """Each element's wrench from the core (mjflex.wrench_on_b and mjflex.stop_wrench_on_b on the sites' world poses,
    the rest offset removed, MuJoCo's site velocities) applied at frame b's origin by mj_applyFT; also the sum of
    |contributions| per dof."""
    total, scale = np.zeros(model.nv), np.zeros(model.nv)
    rows = flex.element_table.elements
    for e, rec in enumerate(flex.records):
        row = rows[e]
        if not row["enabled"]:
            continue
        sa, sb = flex.site_ids[e]
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ row["R0"].reshape(3, 3).T
        p_b = data.site_xpos[sb] - R_b @ row["p0"]
        vel = []
        for site, point in ((sa, p_a), (sb, p_b)):
            v = np.empty(6)
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, int(site), v, 0)
            vel += [v[:3], v[3:] + np.cross(v[:3], point - data.site_xpos[site])]
        viscous = {"B": rec.B, "w_WA": vel[0], "v_WA": vel[1], "w_WB": vel[2], "v_WB": vel[3]} if row["viscous"] else {}
        W = mjflex.wrench_on_b(R_a, p_a, R_b, p_b, rec.K, method=("twist", "dualquat")[row["method"]],
                               terms=rec.terms, **viscous)  # fmt: skip
        if rec.stops:
            limits = (*rec.stops.limits_for(6), rec.stops.stiffness_for(rec.K))
            W = W + mjflex.stop_wrench_on_b(R_a, p_a, R_b, p_b, *limits)
        for sign, body in ((1.0, model.site_bodyid[sb]), (-1.0, model.site_bodyid[sa])):
            one = np.zeros(model.nv)
            mujoco.mj_applyFT(model, data, sign * W[3:], sign * W[:3], p_b, body, one)
            total += one
            scale += np.abs(one)
    return total, scale


@pytest.mark.parametrize("which", ["mixed", "arcade", "hinge chain"])
@pytest.mark.parametrize("angle", [1e-3, 0.3, 3.0])
def test_generalized_forces_are_each_wrench_applied_at_frame_b(which, angle):
    """The loop's map to generalized forces (free joints: body-frame moments from the element's local frames; dof
    chains: the Jacobian at frame b) against MuJoCo's mj_applyFT of the core's wrench at frame b's origin."""
    if which == "hinge chain":
        model = mujoco.MjModel.from_xml_string(hinge_chain_spec(B=0.01 * np.eye(6)).to_xml())
    else:
        model = mixed_model() if which == "mixed" else mujoco.MjModel.from_xml_path("models/arcade.xml")
    flex = mjflex.Flexures(model)
    assert flex.element_table.elements["offset"][: len(flex)].any()  # saved files: rest offsets to remove
    data = _moved(model, np.random.default_rng(11), angle)
    if which == "hinge chain":
        data.qpos[:] = model.qpos0 + angle * np.random.default_rng(2).normal(size=model.nq) * (model.nq > 0)
        for j in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_BALL):
            adr = model.jnt_qposadr[j]
            data.qpos[adr : adr + 4] /= np.linalg.norm(data.qpos[adr : adr + 4])
        mujoco.mj_forward(model, data)
    expected, scale = _core_generalized_forces(model, data, flex)
    got = flex.generalized_forces(data)
    assert np.all(np.abs(got - expected) <= 1e-12 * scale + 1e-300), np.max(np.abs(got - expected) / (scale + 1e-300))


def test_a_one_lane_build_gives_the_same_bits(tmp_path):
    """The portable build (a C compiler without GNU vector extensions; here GCC told so by -DMJFX_SCALAR) evaluates
    one element at a time: the same bits as the vector builds, for every query and in every branch."""
    folder = os.path.dirname(mujoco.__file__)
    lib = next(f for f in os.listdir(folder) if f.startswith("libmujoco.so."))
    cc = c_compiler()
    native = os.path.join(os.path.dirname(_native.__file__), "..", "native")
    sources = sorted(os.path.join(native, f) for f in os.listdir(native) if f.endswith(".c"))
    copy = tmp_path / "libmjflex-scalar.so"
    # another header version: the copy does not register the plugin a second time (its functions still work)
    subprocess.run([cc, "-O2", "-shared", "-fPIC", "-std=c11", "-fexceptions", "-fno-math-errno", "-ffp-contract=off",
                    "-DMJFX_SCALAR", "-DMJFX_HEADER_VERSION=3999999", f"-I{os.path.join(folder, 'include')}", *sources,
                    "-o", str(copy), f"-L{folder}", f"-l:{lib}", f"-Wl,-rpath,{folder}", "-lm"],
                   check=True, capture_output=True)  # fmt: skip
    code = f"""
import ctypes
import numpy as np
import mjflex
from mjflex.native import library as _native
from tests.test_native_kernel import mixed_model, _moved

copy = ctypes.CDLL({str(copy)!r})
copy.mjfx_evaluate.restype, copy.mjfx_evaluate.argtypes = _native._SIGNATURES["mjfx_evaluate"]
assert copy.mjfx_lanes() == 1 and copy.mjfx_set_lanes(2) == -1
model = mixed_model()
flex = mjflex.Flexures(model)
t, n = flex.element_table, len(flex)
for seed, angle in ((1, 1e-3), (2, 0.3), (3, 3.0)):
    data = _moved(model, np.random.default_rng(seed), angle)
    for mode in (_native.APPLY | _native.WRENCH | _native.POWER, _native.ENERGY, _native.COORDS):
        out = []
        for evaluate in (copy.mjfx_evaluate, _native.lib().mjfx_evaluate):
            qfrc, out6, out1 = np.zeros(model.nv), np.zeros((n, 6)), np.zeros(n)
            evaluate(model._address, data._address, t.elements.ctypes.data, n, t.chain.ctypes.data,
                     t.exps.ctypes.data, t.coefs.ctypes.data, mode, qfrc.ctypes.data, out6.ctypes.data,
                     out1.ctypes.data, None)
            out.append((qfrc, out6, out1))
        assert all(np.array_equal(a, b) for a, b in zip(*out)), (seed, mode)
print("same bits", _native.lanes())
"""
    root = os.path.join(os.path.dirname(__file__), "..")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root)
    assert result.returncode == 0, result.stderr
    assert "same bits" in result.stdout
