"""Polynomial (higher-order) elements in MJCF and in the provider.

References: the core functions (``mjflex.wrench_on_b`` / ``potential`` with ``terms=``, themselves
tested against finite differences), MuJoCo's ``mj_applyFT`` for the generalized forces, energy
conservation of MuJoCo's own integration, and serial stepping for rollout threads.
"""

import json
import os

import mujoco
import numpy as np
import pytest

import mjflex
from tests.models import (
    B_DEMO,
    K_DEMO,
    applied_wrenches_reference,
    demo_terms,
    hinge_chain_spec,
    perturb_joints,
    rollout_and_serial,
    two_body_spec,
)

pytestmark = pytest.mark.usefixtures("clean_callback")
METHODS = ["twist", "dualquat"]


def _moved(model, seed=0, rot=0.15, trans=0.01, speed=0.3):
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    for body in range(1, model.nbody):
        jnt = model.body_jntadr[body]
        if model.body_jntnum[body] == 1 and model.jnt_type[jnt] == mujoco.mjtJoint.mjJNT_FREE:
            adr = model.jnt_qposadr[jnt]
            data.qpos[adr : adr + 3] += trans * rng.normal(size=3)
            dq = np.r_[1.0, rot / 2 * rng.normal(size=3)]
            q = np.empty(4)
            mujoco.mju_mulQuat(q, data.qpos[adr + 3 : adr + 7].copy(), dq / np.linalg.norm(dq))
            data.qpos[adr + 3 : adr + 7] = q
    data.qvel[:] = speed * rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)
    return data


def _site_velocity(model, data, site):
    res = np.empty(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, site, res, 0)
    return res[:3], res[3:]


@pytest.mark.parametrize("method", METHODS)
def test_provider_matches_the_core_functions(method):
    terms = demo_terms(method)
    model = two_body_spec(method=method, B=B_DEMO, terms=terms).compile()
    flex = mjflex.Flexures(model)
    assert flex.records[0].order == 4 and len(flex.records[0].terms) == len(terms)
    for seed in range(5):
        data = _moved(model, seed)
        Ra, Rb = data.site_xmat[0].reshape(3, 3), data.site_xmat[1].reshape(3, 3)
        pa, pb = data.site_xpos[0], data.site_xpos[1]
        (wa, va), (wb, vb) = _site_velocity(model, data, 0), _site_velocity(model, data, 1)
        W = mjflex.wrench_on_b(Ra, pa, Rb, pb, K_DEMO, method=method, B=B_DEMO, terms=terms,
                               w_WA=wa, v_WA=va, w_WB=wb, v_WB=vb)  # fmt: skip
        U = mjflex.potential(Ra, pa, Rb, pb, K_DEMO, method=method, terms=terms)
        U2 = mjflex.potential(Ra, pa, Rb, pb, K_DEMO, method=method)
        assert U > 0 and abs(U - U2) > 1e-3 * U  # the terms matter in these states (compared to 1e-12)
        np.testing.assert_allclose(flex.wrenches(data)[0], W, rtol=0, atol=1e-12 * np.abs(W).max())
        assert abs(flex.potential_energy(data) - U) <= 1e-12 * U


@pytest.mark.parametrize("method", METHODS)
def test_chain_generalized_forces_equal_mj_applyFT(method):
    terms = demo_terms(method, seed=1)
    model = hinge_chain_spec(n=4, B=B_DEMO, method=method, terms=terms).compile()
    data = mujoco.MjData(model)
    perturb_joints(model, data, np.random.default_rng(1), angle=0.2, other=0.3)
    flex = mjflex.Flexures(model)
    expected = applied_wrenches_reference(model, data, flex)
    got = flex.generalized_forces(data)
    assert np.linalg.norm(got - expected) <= 1e-12 * np.linalg.norm(expected)
    before = data.qfrc_passive.copy()
    with flex:  # the native callback adds exactly these
        mujoco.mj_forward(model, data)
    assert np.linalg.norm(data.qfrc_passive - before - got) <= 1e-12 * np.linalg.norm(got)


@pytest.mark.parametrize("method", METHODS)
def test_energy_is_conserved_with_polynomial_terms(method):
    """MuJoCo's RK4 with the callback: kinetic plus element energy stays constant (wrench = -grad U)."""
    model = two_body_spec(method=method, terms=demo_terms(method, seed=2), timestep=5e-4).compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = _moved(model, seed=3)
    flex = mjflex.Flexures(model)

    def energy():
        mujoco.mj_forward(model, data)
        return data.energy[1] + flex.potential_energy(data)

    E0, drift = energy(), 0.0
    with flex:
        for _ in range(6):
            for _ in range(500):
                mujoco.mj_step(model, data)
            drift = max(drift, abs(energy() - E0) / E0)
    assert flex.potential_energy(data) > 0.05 * E0
    assert drift <= 1e-6


def test_rollout_threads_match_serial_stepping():
    """The terms' work arrays live on each thread's stack: threaded rollouts equal serial stepping."""
    model = two_body_spec(method="dualquat", B=B_DEMO, integrator="Euler", terms=demo_terms("dualquat")).compile()
    data = _moved(model, seed=4)
    with mjflex.Flexures(model):
        states, final = rollout_and_serial(model, data, 200, threads=3)
    assert np.array_equal(states[:, -1], np.tile(final, (4, 1)))


def test_model_file_round_trip_keeps_every_digit(tmp_path):
    terms = demo_terms("twist", order=6)
    spec = two_body_spec(B=B_DEMO, terms=terms)
    path = os.path.join(tmp_path, "model.xml")
    with open(path, "w") as f:
        f.write(spec.to_xml())
    again = mjflex.Flexures(mujoco.MjModel.from_xml_path(path))
    rec = again.records[0]
    assert rec.order == 6
    np.testing.assert_array_equal(rec.terms.exponents, terms.exponents)
    np.testing.assert_array_equal(rec.terms.coefficients, terms.coefficients)


def test_switches_and_spring_flag_act_on_the_terms():
    terms = demo_terms("twist")
    model = two_body_spec(B=B_DEMO, terms=terms).compile()
    flex = mjflex.Flexures(model)
    data = _moved(model, seed=5)
    with pytest.raises(ValueError, match="polynomial terms in twist coordinates"):
        flex.set_method("link", "dualquat")
    flex.set_method("link", "twist")  # no change: allowed
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SPRING
    assert flex.potential_energy(data) == 0.0  # the terms are elastic: off with the springs
    viscous = flex.wrenches(data)[0]
    (wa, va), (wb, vb) = _site_velocity(model, data, 0), _site_velocity(model, data, 1)
    Ra, Rb = data.site_xmat[0].reshape(3, 3), data.site_xmat[1].reshape(3, 3)
    ref = mjflex.wrench_on_b(Ra, data.site_xpos[0], Rb, data.site_xpos[1], np.zeros((6, 6)), B=B_DEMO,
                             w_WA=wa, v_WA=va, w_WB=wb, v_WB=vb)  # fmt: skip
    np.testing.assert_allclose(viscous, ref, rtol=0, atol=1e-13 * np.abs(ref).max())


def test_terms_given_in_another_frame_are_moved_to_the_element_frame():
    """add_flexure(stiffness_frame=...) moves K and the terms together (eq. 69): the same energy."""
    terms = demo_terms("twist", seed=6)
    spec = two_body_spec()
    for t in list(spec.texts):
        spec.delete(t)
    for s in ("link/a", "link/b"):
        spec.delete(spec.site(s))
    F_pos, F_quat = np.array([0.12, 0.0, 0.52]), np.array([0.9, 0.3, 0.1, -0.2]) / np.linalg.norm([0.9, 0.3, 0.1, -0.2])
    mjflex.add_flexure(spec, "link", "A", "B", pos=[0.1, 0.02, 0.5], quat=[0.8, 0, 0.6, 0], K=K_DEMO, terms=terms,
                       stiffness_frame=(F_pos, F_quat))  # fmt: skip
    model = spec.compile()
    flex = mjflex.Flexures(model)
    data0 = mujoco.MjData(model)
    mujoco.mj_forward(model, data0)
    R_WF0 = np.empty(9)
    mujoco.mju_quat2Mat(R_WF0, F_quat)
    R_WF0 = R_WF0.reshape(3, 3)
    data = _moved(model, seed=7)
    frames = []
    for body in (1, 2):  # frame F carried by each body from the reference configuration
        R0, p0 = data0.xmat[body].reshape(3, 3), data0.xpos[body]
        R, p = data.xmat[body].reshape(3, 3), data.xpos[body]
        frames += [R @ R0.T @ R_WF0, p + R @ R0.T @ (F_pos - p0)]
    U = mjflex.potential(*frames, K_DEMO, terms=terms)
    assert abs(flex.potential_energy(data) - U) <= 1e-9 * U


def _record(**changes):
    data = {"mjflex": 1, "method": "twist", "K": K_DEMO.tolist(), "order": 4,
            "terms": {"exponents": [[3, 0, 0, 0, 0, 0], [0, 0, 0, 2, 0, 2]], "coefficients": [1.0, 2.0]}}  # fmt: skip
    data.update(changes)
    return json.dumps({k: v for k, v in data.items() if v is not None})


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (_record(order=None), r"terms.exponents row 0 has degree 3, above order 2; raise order"),  # 2: the default
        (_record(order=2), r"row 0 has degree 3, above order 2"),
        (_record(order=3, terms=None), r"order is 3 but there are no terms; add terms.exponents and"),
        (_record(method="dualquat", order=3), r"order must be an integer >= 2 and even"),
        (_record(method="dualquat"), r"terms.exponents has 12 integers, not a multiple of 8"),
        (_record(terms={"exponents": [[1, 0, 0, 0, 0, 0]], "coefficients": [1.0]}), "linear term"),
        (
            _record(terms={"exponents": [[3, 0, 0, 0, 0, 0]], "coefficients": ["x"]}),
            r"coefficients\[0\] is the text 'x': numbers are expected",
        ),
        (_record(terms={"exponents": [[3, 0, 0, 0, 0, 0]]}), r"1 rows of exponents but 0 coefficients"),
        (_record(terms={"exponents": [[3, 0, 0, 0, 0, 0]], "coefs": [1.0]}), r'"terms" has unknown key\(s\) \[\'coefs'),
        (_record(terms={"exponents": [[0, 0, 0, 2, 0, 0]], "coefficients": [-1e3]}), "not positive semi-definite"),
        (
            _record(method="dualquat", terms={"exponents": [[1, 0, 0, 0, 0, 1, 0, 0]], "coefficients": [1.0]}),
            "stressed at rest",
        ),
    ],
)
def test_malformed_terms_name_the_element_and_the_fix(data, match):
    spec = two_body_spec()
    spec.text("mjflex:link").data = data
    with pytest.raises(mjflex.ModelError, match=r"flexure 'link': .*" + match):
        mjflex.Flexures(spec.compile())


def test_linear_variants_say_that_they_drop_the_terms():
    """mjflex.reduce keeps an element that stays whole with its terms; MuJoCo-native variants report them as lost."""
    terms = demo_terms("twist")
    weld = mjflex.weld_variant(two_body_spec(terms=terms))
    assert "link: its polynomial terms (order 4, 182 terms) are not represented" in weld.report
    reduced = mjflex.reduce(two_body_spec(terms=terms), keep_below_hz=1e5)
    assert "link: its polynomial terms (order 4, 182 terms) are kept if it stays a full 3-D element" in reduced.report
    kept = mjflex.Flexures(reduced.model).records[0]
    np.testing.assert_array_equal(kept.terms.coefficients, terms.coefficients)
