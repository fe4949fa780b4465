"""Divergence, for the engine plugin and the mjcb_passive provider alike (mjflex.runtime.divergence).

Forces at a finite state are finite and exact in mj_forward / mj_inverse (issue 15 section 1); a step that
MuJoCo finds bad is reported with the element, in "the step from t = ... s (step index k, counting from 0)";
once per element per run, the repeats counted (issue 17 item 6).
"""

import contextlib
import os
import subprocess
import sys
import warnings

import mujoco
import numpy as np
import pytest
from mujoco import batch as mjbatch

import mjflex
from tests.helpers import c_output
from tests.models import B_DEMO, two_body_spec

pytestmark = pytest.mark.usefixtures("clean_callback")
KINDS = ["record", "plugin"]


def _provided(model):
    """The provider installed for a text-record model; nothing for a plugin model (its forces are its own)."""
    flex = mjflex.Flexures(model)
    return flex, (flex if flex.kinds[0] == "record" else contextlib.nullcontext())


def _light_body(kind, integrator="RK4"):
    """A 1 mg body on a free joint, tied to the world by a 1e6 N/m element (issue 15's repro)."""
    spec = mujoco.MjSpec()
    spec.modelname = "light"
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    body = spec.worldbody.add_body(name="B", pos=[0, 0, 0.5], mass=1e-6, inertia=[1e-12] * 3)
    body.explicitinertial = True
    body.add_freejoint()
    K = np.diag([1e-3, 1e-3, 1e-3, 1e6, 1e6, 1e6])
    mjflex.add_flexure(spec, "spring", "world", "B", pos=[0, 0, 0.5], K=K, kind=kind)
    return spec.compile()


@pytest.mark.parametrize("kind", KINDS)
def test_forward_and_inverse_at_a_large_finite_deflection_are_exact(kind, capfd):
    model = _light_body(kind)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET  # the strictest setting: errors would raise
    data = mujoco.MjData(model)
    data.qpos[0] += 0.02  # stretched 2 cm: 2e4 N on 1 mg, 2e10 m/s^2 (beyond mjMAXVAL, yet a valid state)
    flex, provided = _provided(model)
    with provided:
        mujoco.mj_forward(model, data)
        forward = data.qfrc_passive.copy()
        mujoco.mj_inverse(model, data)
    assert np.isfinite(forward).all() and np.isfinite(data.qfrc_inverse).all()
    assert np.isclose(forward[0], -2e4, rtol=1e-12) and np.abs(forward[1:]).max() <= 1e-12 * 2e4
    assert np.array_equal(forward, flex.generalized_forces(data))
    assert "mjflex" not in c_output(capfd)  # nothing reported: a large force is not divergence
    assert flex.divergences(data) == {}


@pytest.mark.parametrize("kind", KINDS)
def test_the_step_that_diverges_is_reported_with_auto_reset_off(kind):
    """mj_step of that state: MuJoCo's acceleration check fires, and the element is named in that step."""
    model = _light_body(kind)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    data = mujoco.MjData(model)
    data.qpos[0] += 0.02
    message = (r"mjflex: flexure 'spring' of model 'light' diverged in the step from t = 0 s \(step index 0, "
               r"counting from 0\): MuJoCo found a bad qacc, and this element's force alone accelerates one of its "
               r"bodies at 2e\+10")  # fmt: skip
    _, provided = _provided(model)
    with provided, warnings.catch_warnings(), pytest.raises(mujoco.FatalError, match=message):
        mujoco.mj_step(model, data)  # RK4: the callback's next evaluation is in this step, the plugin's advance too
    # the MuJoCo error left the data usable: reset and step on
    mujoco.mj_resetData(model, data)
    with provided:
        for _ in range(50):
            mujoco.mj_step(model, data)
    assert np.isfinite(data.qpos).all() and data.time > 0


@pytest.mark.parametrize("kind", KINDS)
def test_a_non_finite_state_is_reported_at_once(kind):
    model = two_body_spec(B=B_DEMO, kind=kind).compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    data = mujoco.MjData(model)
    data.qvel[7] = np.nan
    _, provided = _provided(model)
    with provided, pytest.raises(mujoco.FatalError, match=r"flexure 'link' .*: its wrench is not finite"):
        mujoco.mj_forward(model, data)


def _diverge_repeatedly(model, data, steps):
    """Euler far beyond its stable step: after each auto-reset the round-off grows again and diverges."""
    for _ in range(steps):
        mujoco.mj_step(model, data)


@pytest.mark.parametrize("kind", [*KINDS, "python dispatcher"])
def test_divergence_is_printed_once_per_run_and_the_repeats_counted(kind, capfd):
    form = kind.replace("python dispatcher", "record")
    model = two_body_spec(B=B_DEMO, integrator="Euler", timestep=0.5, kind=form).compile()
    if kind == "python dispatcher":  # a user's Python callback installed first: mjflex chains it, the same rules
        mujoco.set_mjcb_passive(lambda m, d: None)  # (clean_callback removes it)
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    flex, provided = _provided(model)
    with provided:
        _diverge_repeatedly(model, data, 60)
    out = c_output(capfd)
    assert out.count("mjflex: flexure 'link'") == 1  # 19-24 identical lines in a 278-step run before
    assert out.count("Nan, Inf or huge value") == 1  # MuJoCo's own warning: once as well
    assert "in this run (until mj_resetData) are counted, not printed" in out
    found = flex.divergences(data)["link"]
    assert found.count >= 3 and found.time == 1.5 and found.step == 3 and not found.pending
    assert found.message.startswith("mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 1.5 s")
    # the user's reset starts a new run: reported again, counted from 1
    mujoco.mj_resetData(model, data)
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    with provided:
        _diverge_repeatedly(model, data, 4)
    assert c_output(capfd).count("mjflex: flexure 'link'") == 1
    assert flex.divergences(data)["link"].count == 1


def test_the_callback_counts_per_mjData():
    """Two MjData of one model: two runs, each reported once."""
    model = two_body_spec(B=B_DEMO, integrator="Euler", timestep=0.5).compile()
    flex = mjflex.Flexures(model)
    datas = [mujoco.MjData(model) for _ in range(2)]
    for d in datas:
        d.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    with flex:
        for _ in range(60):
            for d in datas:
                mujoco.mj_step(model, d)
    counts = [flex.divergences(d)["link"].count for d in datas]
    assert counts[0] == counts[1] >= 3


@pytest.mark.parametrize("kind", KINDS)
def test_batch_threads_report_the_element(kind):
    model = two_body_spec(B=B_DEMO, integrator="Euler", timestep=0.5, kind=kind).compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    flex = mjflex.Flexures(model)
    batch = mjbatch.Batch(model, nsim=4, nthread=2)
    if kind == "record":
        flex.serve(batch)
    batch.qvel = [np.random.default_rng(seed).normal(size=model.nv) for seed in range(4)]
    with flex, pytest.raises(mjbatch.SimulationError) as info:
        batch.step(nstep=10)
    assert info.value.ids.tolist() == [0, 1, 2, 3]
    assert all("flexure 'link' of model 'two_body' diverged in the step from t = " in batch.error(i) for i in range(4))


ROLLOUT = """
import mujoco, numpy as np
from mujoco import rollout
from tests.models import two_body_spec, B_DEMO
model = two_body_spec(B=B_DEMO, integrator="Euler", kind="plugin").compile()
model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
state = np.zeros(mujoco.mj_stateSize(model, kind))
mujoco.mj_getState(model, mujoco.MjData(model), state, kind)
state[1 + 7] = np.nan
states, _ = rollout.rollout([model] * 2, [mujoco.MjData(model) for _ in range(2)], np.tile(state, (2, 1)), nstep=5)
print("survived", np.isnan(states).any())
"""


def test_plugin_in_rollout_threads_warns_instead_of_ending_the_process():
    """In MuJoCo's own worker threads an error would end the process: the plugin warns there."""
    root = os.path.join(os.path.dirname(__file__), "..")
    result = subprocess.run([sys.executable, "-c", ROLLOUT], cwd=root, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "survived True" in result.stdout
    assert (
        "mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 0 s" in result.stdout + result.stderr
    )
