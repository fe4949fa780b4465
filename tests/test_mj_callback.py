"""The process-global callback: installation, several models, file round trips, errors and switches."""

import ctypes
import os

import mujoco
import numpy as np
import pytest

import mjflex
from tests.models import B_DEMO, K_DEMO, rollout_and_serial, two_body_spec

PLAIN_XML = '<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>'


pytestmark = pytest.mark.usefixtures("clean_callback")


def _run(model, steps, flex=None, seed=0):
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(seed).normal(size=model.nv)
    out = []
    for _ in range(steps):
        mujoco.mj_step(model, data)
        out.append(data.qpos.copy())
    return np.array(out)


def test_native_dispatcher_is_used():
    flex = mjflex.Flexures(two_body_spec().compile())
    with flex:
        assert isinstance(mujoco.get_mjcb_passive(), ctypes._CFuncPtr)
        assert flex.installed
    assert mujoco.get_mjcb_passive() is None and not flex.installed


def test_compiling_models_while_installed():
    """A Python passive callback breaks mj_compile; the native dispatcher does not."""
    flex = mjflex.Flexures(two_body_spec().compile())
    with flex:
        other = mujoco.MjModel.from_xml_string(PLAIN_XML)
        spec_model = two_body_spec(method="dualquat").compile()
        assert other.nbody == 2 and spec_model.nbody == 3


def test_adds_to_qfrc_passive_and_leaves_applied_forces_alone():
    spec = two_body_spec(B=B_DEMO)
    for j in spec.joints:
        j.damping = [0.3, 0.0, 0.0]  # MuJoCo's own passive forces are kept
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    data.xfrc_applied[1] = [1, 2, 3, 4, 5, 6]
    data.qfrc_applied[:] = 0.5
    mujoco.mj_forward(model, data)
    native = data.qfrc_passive.copy()
    flex = mjflex.Flexures(model)
    with flex:
        mujoco.mj_forward(model, data)
    assert np.abs(native).max() > 0
    assert np.allclose(data.qfrc_passive, native + flex.generalized_forces(data), rtol=1e-13, atol=1e-15)
    assert np.array_equal(data.xfrc_applied[1], [1, 2, 3, 4, 5, 6]) and np.all(data.qfrc_applied == 0.5)


def test_models_with_and_without_elements_interleaved():
    m1 = two_body_spec(method="twist", B=B_DEMO).compile()
    m2 = two_body_spec(method="dualquat", K=2 * K_DEMO).compile()
    m3 = mujoco.MjModel.from_xml_string(PLAIN_XML)
    f1, f2 = mjflex.Flexures(m1), mjflex.Flexures(m2)
    with f1:
        alone1 = _run(m1, 300)
    with f2:
        alone2 = _run(m2, 300)
    alone3 = _run(m3, 300)
    with f1, f2:
        d1, d2, d3 = (mujoco.MjData(m) for m in (m1, m2, m3))
        for d, m in ((d1, m1), (d2, m2), (d3, m3)):
            d.qvel[:] = np.random.default_rng(0).normal(size=m.nv)
        got = {1: [], 2: [], 3: []}
        for _ in range(300):
            for i, (m, d) in enumerate(((m1, d1), (m2, d2), (m3, d3)), start=1):
                mujoco.mj_step(m, d)
                got[i].append(d.qpos.copy())
    assert np.array_equal(np.array(got[1]), alone1)
    assert np.array_equal(np.array(got[2]), alone2)
    assert np.array_equal(np.array(got[3]), alone3)


def test_previous_python_callback_is_chained_and_restored():
    calls = []

    def user_callback(m, d):
        calls.append(m.nbody)
        d.qfrc_passive[0] += 1.0

    model = two_body_spec().compile()  # MuJoCo cannot compile while a Python callback is installed
    data = mujoco.MjData(model)
    mujoco.set_mjcb_passive(user_callback)
    flex = mjflex.Flexures(model)
    with flex:
        mujoco.mj_forward(model, data)
        assert calls and flex.installed
        expected = flex.generalized_forces(data)
        expected[0] += 1.0
        assert np.allclose(data.qfrc_passive, expected, rtol=1e-13, atol=1e-15)
    assert mujoco.get_mjcb_passive() is user_callback


def test_previous_native_callback_is_chained_and_restored():
    hits = ctypes.c_int(0)

    @ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
    def user_native(m, d):
        hits.value += 1

    mujoco.set_mjcb_passive(user_native)
    model = two_body_spec().compile()
    flex = mjflex.Flexures(model)
    with flex:
        assert mujoco.get_mjcb_passive() is not user_native
        before = hits.value
        mujoco.mj_forward(model, mujoco.MjData(model))
        assert hits.value == before + 1
    assert mujoco.get_mjcb_passive() is user_native


def _passive(model, data):
    data.qfrc_passive[:] = 0.0
    mujoco.mj_forward(model, data)
    return data.qfrc_passive.copy()


def test_nested_installs_of_one_provider_are_counted():
    model, data, flex = _displaced_moving()
    expected = flex.generalized_forces(data)
    with flex:
        with flex:  # the inner exit must not uninstall what the outer block installed
            assert flex.installed
        assert flex.installed
        assert np.array_equal(_passive(model, data), expected)
    assert not flex.installed and mujoco.get_mjcb_passive() is None
    flex.uninstall()  # more uninstalls than installs: nothing to undo
    assert mujoco.get_mjcb_passive() is None


def test_nested_providers_of_one_model_innermost_serves():
    model, data, outer = _displaced_moving()
    inner = mjflex.Flexures(model)
    inner.set_viscous("link", False)
    f_outer, f_inner = outer.generalized_forces(data), inner.generalized_forces(data)
    assert np.abs(f_outer - f_inner).max() > 1e-9 * np.abs(f_outer).max()
    with outer:
        with inner:  # the inner provider replaces the outer one: never both (no double forces)
            assert inner.installed and not outer.installed
            assert np.array_equal(_passive(model, data), f_inner)
        assert outer.installed
        assert np.array_equal(_passive(model, data), f_outer)
    # out of order: the outer one uninstalled first, the inner one keeps serving
    outer.install()
    inner.install()
    outer.uninstall()
    assert inner.installed and np.array_equal(_passive(model, data), f_inner)
    inner.uninstall()
    assert mujoco.get_mjcb_passive() is None and np.all(_passive(model, data) == 0)


def test_model_without_elements_is_untouched():
    model = mujoco.MjModel.from_xml_string(PLAIN_XML)
    flex = mjflex.Flexures(model)
    with flex:
        assert len(flex) == 0 and mujoco.get_mjcb_passive() is None


def test_nan_state_raises_with_the_element_name():
    model = two_body_spec(B=B_DEMO).compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    data = mujoco.MjData(model)
    data.qvel[7] = np.nan
    # the convention of every mjflex message (mjflex.runtime.divergence): the step that starts at t, indexed from 0
    message = r"mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 0 s \(step index 0, counting"
    with mjflex.Flexures(model), pytest.raises(mujoco.FatalError, match=message):
        mujoco.mj_forward(model, data)
    # the element name also comes back from the Python-side evaluation
    with pytest.raises(mujoco.FatalError, match="flexure 'link'"):
        mjflex.Flexures(model).wrenches(data)


def _displaced_moving():
    """The two-body model with B displaced and everything moving."""
    model = two_body_spec(B=B_DEMO).compile()
    data = mujoco.MjData(model)
    data.qpos[7:10] += [0.01, -0.02, 0.005]
    data.qvel[:] = 1.0
    mujoco.mj_forward(model, data)
    return model, data, mjflex.Flexures(model)


def test_run_time_switches():
    model, data, flex = _displaced_moving()
    full = flex.wrenches(data)[0]
    flex.set_viscous("link", False)
    elastic = flex.wrenches(data)[0]
    assert not np.allclose(full, elastic)
    flex.set_method("link", "dualquat")
    assert flex.methods == ("dualquat",)
    assert not np.array_equal(flex.wrenches(data)[0], elastic)
    flex.set_enabled("link", False)
    assert np.all(flex.wrenches(data) == 0) and np.all(flex.generalized_forces(data) == 0)
    with flex:
        before = data.qfrc_passive.copy()
        mujoco.mj_forward(model, data)
        assert np.array_equal(data.qfrc_passive, before)
    with pytest.raises(KeyError, match=r"no flexure named 'lnk'; did you mean \['link'\]"):
        flex.set_enabled("lnk", True)
    undamped = mjflex.Flexures(two_body_spec().compile())
    with pytest.raises(ValueError, match="has no damping matrix B"):
        undamped.set_viscous("link", True)


def test_mujoco_spring_and_damper_flags():
    model, data, flex = _displaced_moving()
    full = flex.generalized_forces(data)
    model.opt.disableflags = mujoco.mjtDisableBit.mjDSBL_DAMPER
    elastic = flex.generalized_forces(data)
    model.opt.disableflags = mujoco.mjtDisableBit.mjDSBL_SPRING
    viscous = flex.generalized_forces(data)
    assert flex.potential_energy(data) == 0.0
    assert np.allclose(elastic + viscous, full, rtol=1e-12, atol=1e-15)
    assert np.abs(elastic).max() > 0 and np.abs(viscous).max() > 0
    with flex:  # the native callback reads the same flags
        data.qfrc_passive[:] = 0.0
        mujoco.mj_forward(model, data)
    assert np.allclose(data.qfrc_passive, viscous, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("writer", ["to_xml", "mj_saveLastXML"])
def test_model_file_round_trip(tmp_path, writer):
    spec = two_body_spec(B=B_DEMO)
    model = spec.compile()
    path = os.path.join(tmp_path, "model.xml")
    if writer == "to_xml":
        with open(path, "w") as f:
            f.write(spec.to_xml())
    else:
        mujoco.mj_saveLastXML(path, model)
    again = mujoco.MjModel.from_xml_path(path)
    a, b = mjflex.Flexures(model), mjflex.Flexures(again)
    assert a.names == b.names
    assert np.array_equal(a.records[0].K, b.records[0].K) and np.array_equal(a.records[0].B, b.records[0].B)
    # the reloaded model is unstressed at qpos0, although its site poses were rounded to 6 digits
    data = mujoco.MjData(again)
    mujoco.mj_forward(again, data)
    # achieved 1e-17 N and 1e-34 J; without the rest offset the rounding would leave ~1e-5 N and ~1e-11 J
    assert np.abs(b.wrenches(data)).max() <= 1e-15
    assert b.potential_energy(data) <= 1e-28
    # and it behaves like the original
    with a:
        ta = _run(model, 200)
    with b:
        tb = _run(again, 200)
    assert np.abs(ta - tb).max() <= 1e-5


def test_threaded_rollout_matches_serial_stepping():
    """The native callback needs no GIL: mujoco.rollout threads apply the flexures too, identically."""
    from mujoco import rollout

    model = two_body_spec(B=B_DEMO, integrator="Euler").compile()
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(2).normal(size=model.nv)
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data, state0, kind)
    with mjflex.Flexures(model):
        states, final = rollout_and_serial(model, data, 300)
    assert np.array_equal(states[:, -1], np.tile(final, (4, 1)))
    free, _ = rollout.rollout(model, mujoco.MjData(model), state0, nstep=300)  # not installed: no flexure forces
    assert np.abs(free[0, -1] - final).max() > 1e-3


ROLLOUT_NAN = """
import mujoco, numpy as np
from mujoco import rollout
import mjflex
from tests.models import two_body_spec, B_DEMO
model = two_body_spec(B=B_DEMO, integrator="Euler").compile()
model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
state = np.zeros(mujoco.mj_stateSize(model, kind))
mujoco.mj_getState(model, mujoco.MjData(model), state, kind)
state[1 + 7] = np.nan
if CHAINED:  # a Python callback installed before mjflex: the Python dispatcher chains it
    mujoco.set_mjcb_passive(lambda m, d: None)
with mjflex.Flexures(model):
    states, _ = rollout.rollout([model] * 2, [mujoco.MjData(model) for _ in range(2)], np.tile(state, (2, 1)), nstep=5)
print("survived", np.isnan(states).any())
"""


@pytest.mark.parametrize("chained", [False, True], ids=["native", "python-dispatcher"])
def test_diverging_rollout_threads_warn_instead_of_ending_the_process(chained):
    """In MuJoCo's own threads an error would end the process; the element is reported as a warning."""
    import subprocess
    import sys

    root = os.path.join(os.path.dirname(__file__), "..")
    script = f"CHAINED = {chained}\n" + ROLLOUT_NAN
    result = subprocess.run([sys.executable, "-c", script], cwd=root, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "survived True" in result.stdout
    # a warning (the process survived); without its "WARNING: " prefix, which MuJoCo writes separately and two
    # threads printing at once can move away from the message
    assert (
        "mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 0 s (step index 0, counting from 0)"
        in result.stdout + result.stderr
    )
