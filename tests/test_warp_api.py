"""The boundary of ``mjflex.warp``: data of another model, parameters without worlds, one API (issue 33 items 1, 2;
issue 30 "one Warp API"). On Warp's CPU device, with the two-body model's kernels (cached by Warp after the first run).
"""

import warnings

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp

import mjflex.warp as mw
from mjflex.warp import _forces
from tests.warp_models import features_model

TWO_BODY = "models/two_body_plugin.xml"


@pytest.fixture(scope="module", autouse=True)
def cpu():
    """Every test of the module on Warp's CPU device."""
    with wp.ScopedDevice("cpu"):
        yield


@pytest.fixture(scope="module")
def two_body():
    return mujoco.MjModel.from_xml_path(TWO_BODY)


@pytest.fixture(scope="module")
def features():
    return features_model("plugin")


def _entry_points(m, d):
    """Every function of mjflex.warp that reads a data, and the passive callback that mujoco_warp.step calls."""
    return {
        "wrenches": lambda: mw.wrenches(m, d),
        "generalized_forces": lambda: mw.generalized_forces(m, d),
        "potential_energies": lambda: mw.potential_energies(m, d),
        "dissipation_powers": lambda: mw.dissipation_powers(m, d),
        "displacements": lambda: mw.displacements(m, d),
        "stop_coordinates": lambda: mw.stop_coordinates(m, d),
        "divergences": lambda: mw.divergences(m, d),
        "diverged": lambda: mw.diverged(m, d),
        "clear_divergences": lambda: mw.clear_divergences(m, d),
        "callback": lambda: m.callback.passive(m, d),
    }


def test_data_of_another_model_is_refused_by_every_entry_point(two_body, features):
    """Issue 33 item 1: 1.0.0 returned NaN or garbage for data of another model, and its passive callback wrote out of
    bounds (the process aborted at exit). Both ways round (a smaller and a larger data), every entry point raises
    before a kernel runs, naming the sizes; the data of the model itself still works after a refusal."""
    for model, other in ((two_body, features), (features, two_body)):
        m = mw.put_model(model)
        d = mjw.make_data(other, nworld=2)
        before = d.qfrc_passive.numpy().copy()
        for name, call in _entry_points(m, d).items():
            with pytest.raises(ValueError, match=r"this data is not of the model .*nv = \d+.*make_data\(mjmodel") as e:
                call()
            assert f"nv = {model.nv}" in str(e.value) and f"qvel (2, {other.nv})" in str(e.value), (name, e.value)
        np.testing.assert_array_equal(d.qfrc_passive.numpy(), before)  # nothing written
        own = mjw.make_data(model, nworld=2)
        assert np.isfinite(mw.wrenches(m, own)).all() and not mw.divergences(m, own)


def test_a_parameter_with_zero_worlds_is_refused_at_the_call(two_body):
    """Issue 33 item 2: in 1.0.0 a (0, n, 6, 6) K was accepted and the error came at the next step. Every per-world
    parameter with 0 worlds is refused by set_parameters, and a refused call changes nothing."""
    m = mw.put_model(two_body)
    n = len(mw.flexures(m))
    before = mw.flexures(m).parameters()
    for name, value in (
        ("K", np.zeros((0, n, 6, 6))),
        ("B", np.zeros((0, n, 6))),
        ("enabled", np.zeros((0, n), bool)),
        ("viscous", np.zeros((0, n), bool)),
        ("stop_lower", np.zeros((0, n, 6))),
        ("stop_upper", np.zeros((0, n, 6))),
        ("stop_stiffness", np.zeros((0, n, 6))),
    ):
        with pytest.raises(ValueError, match=rf"^{name} has 0 worlds"):
            mw.set_parameters(m, **{name: value})
    after = mw.flexures(m).parameters()
    assert after.keys() == before.keys()
    for key in before:
        np.testing.assert_array_equal(after[key], before[key])


def test_one_warp_api_the_old_methods_warn_once_and_agree(two_body, monkeypatch):
    """Issue 30 "one Warp API": mjflex.warp's functions are the API; each WarpFlexures method that did the same
    thing warns once (DeprecationWarning naming the function) and gives the function's answer."""
    monkeypatch.setattr(_forces, "_WARNED", set())
    m = mw.put_model(two_body)
    forces = mw.flexures(m)
    data = mujoco.MjData(two_body)
    data.qpos[10:14] = [np.cos(0.05), 0, 0, np.sin(0.05)]
    mujoco.mj_forward(two_body, data)
    d = mjw.put_data(two_body, data, nworld=2)
    same = {
        "wrenches": (lambda: forces.wrenches(m, d), lambda: mw.wrenches(m, d)),
        "generalized_forces": (lambda: forces.generalized_forces(m, d), lambda: mw.generalized_forces(m, d)),
        "dissipation_powers": (lambda: forces.dissipation_powers(m, d), lambda: mw.dissipation_powers(m, d)),
        "potentials_and_twists": (lambda: forces.potentials_and_twists(m, d)[0], lambda: mw.potential_energies(m, d)),
        "divergences": (lambda: forces.divergences(m, d), lambda: mw.divergences(m, d)),
        "diverged": (lambda: forces.diverged(d), lambda: mw.diverged(m, d)),
        "clear_divergences": (lambda: forces.clear_divergences(d), lambda: mw.clear_divergences(m, d)),
    }
    assert set(same) | {"set_parameters"} == set(_forces.DEPRECATED_METHODS)
    for name, (old, new) in same.items():
        with pytest.warns(DeprecationWarning, match=rf"WarpFlexures\.{name} is deprecated; use mjflex\.warp\."):
            got = old()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            again, want = old(), new()  # once: no second warning
        for value in (got, again):
            if isinstance(want, np.ndarray):
                np.testing.assert_array_equal(value, want)
            else:
                assert value == want
    K = forces.parameters()["K"]
    with pytest.warns(DeprecationWarning, match=r"use mjflex\.warp\.set_parameters\(m"):
        forces.set_parameters(K=2 * K)
    np.testing.assert_array_equal(forces.parameters()["K"], 2 * K)
    assert not [n for n in mw.__all__ if n in _forces.DEPRECATED_METHODS and not callable(getattr(mw, n))]


def test_clear_divergences_starts_every_world_anew(two_body):
    m = mw.put_model(two_body)
    d = mjw.make_data(two_body, nworld=3)
    qvel = d.qvel.numpy()
    qvel[1, 0] = np.nan
    d.qvel.assign(qvel)
    m.callback.passive(m, d)
    np.testing.assert_array_equal(mw.diverged(m, d), [False, True, False])
    (found,) = mw.divergences(m, d)  # issue 33 item 7: the message points at the step advice
    assert (
        "mjflex.step_advice(mjmodel) gives the largest stable one" in found.message
        and "normal_modes" not in found.message
    )
    mw.clear_divergences(m, d)
    assert not mw.diverged(m, d).any() and not mw.divergences(m, d)
