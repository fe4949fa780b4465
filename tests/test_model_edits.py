"""A model edited in place after a data stepped (issue 33 item 14).

The native registry knew a model by its address, signature and sizes; an in-place edit (``model.site_pos[...]``,
``model.qpos0[...]``) changes none of them, so 1.0.0 went on with the table read before the edit: finite forces,
14-20 % off, said nowhere. The model's fields that the element reader uses are now compared with a snapshot (once per
step for engine-plugin elements, at every evaluation for text records): a plugin data reads its elements again (as a
new MjData would, with a warning once per data) or, when they can no longer be read, gets NaN forces with a warning; a
text-record model's forces are NaN, with a warning, until a new ``mjflex.Flexures`` is built.
"""

import mujoco
import numpy as np
import pytest

import mjflex
from tests.helpers import c_output
from tests.models import two_body_spec

pytestmark = pytest.mark.usefixtures("clean_callback")


def _stepped(model):
    """A data of ``model`` deflected and stepped 5 times (its state reads the model's elements)."""
    data = mujoco.MjData(model)
    data.qpos[7:10] += [0.004, -0.002, 0.003]
    data.qvel[9:12] = [0.5, -0.2, 0.3]
    mujoco.mj_step(model, data, 5)
    return data


def _move_element(model, shift):
    """Move both sites of element 'link' by ``shift`` (world axes, at qpos0): they still coincide, the element's
    origin moves, so its forces at a deflected state change."""
    ref = mujoco.MjData(model)
    mujoco.mj_kinematics(model, ref)
    for site in ("link/a", "link/b"):
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        body = model.site_bodyid[i]
        model.site_pos[i] += ref.xmat[body].reshape(3, 3).T @ np.asarray(shift)


def _forces(model, data):
    mujoco.mj_forward(model, data)
    return data.qfrc_passive.copy()


def test_a_plugin_data_reads_its_elements_again_after_an_in_place_edit(capfd):
    model = two_body_spec(kind="plugin").compile()
    data = _stepped(model)
    _move_element(model, [0.03, -0.02, 0.01])
    c_output(capfd)
    mujoco.mj_step(model, data)  # the step's first evaluation compares the model with its snapshot
    fresh = mujoco.MjData(model)  # what the edited model gives: its elements read at its qpos0
    fresh.qpos[:], fresh.qvel[:] = data.qpos, data.qvel
    got, want = _forces(model, data), _forces(model, fresh)
    np.testing.assert_array_equal(got, want)
    old = two_body_spec(kind="plugin").compile()  # the model before the edit, at the same state: the stale forces
    stale = mujoco.MjData(old)
    stale.qpos[:], stale.qvel[:] = data.qpos, data.qvel
    assert np.abs(got - _forces(old, stale)).max() > 0.01 * np.abs(want).max()  # the edit matters
    out = c_output(capfd)
    assert out.count("was edited in place after this data was made") == 1, out
    assert "model 'two_body'" in out and "read again" in out
    mujoco.mj_step(model, data, 3)
    assert "edited in place" not in c_output(capfd)  # said once per data


def test_a_plugin_data_whose_elements_cannot_be_read_again_gets_nan_forces(capfd):
    model = two_body_spec(kind="plugin").compile()
    data = _stepped(model)
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "link/b")
    model.site_pos[i] += [0.01, 0, 0]  # the two sites no longer meet at qpos0
    c_output(capfd)
    mujoco.mj_forward(model, data)
    assert np.isnan(data.qfrc_passive).all()
    out = c_output(capfd)
    assert "edited in place after this data was made, cannot be read again: its forces are NaN" in out, out
    assert "apart" in out  # the reader's own message says why


def test_a_text_record_model_edited_after_its_provider_was_built_gets_nan_forces(capfd):
    model = two_body_spec(kind="record").compile()
    flex = mjflex.Flexures(model)
    with flex:  # installed throughout: the install's own check (ModelError for a changed model) comes before
        data = _stepped(model)
        assert np.isfinite(_forces(model, data)).all()
        model.qpos0[0] += 0.05  # a field the reader uses (the rest pose is measured at qpos0)
        c_output(capfd)
        assert np.isnan(_forces(model, data)).all()
        mujoco.mj_step(model, data)
        out = c_output(capfd)
        assert out.count("was edited in place after its mjflex.Flexures was built") == 1, out
        assert "build a new mjflex.Flexures(model)" in out
        model.qpos0[0] -= 0.05  # undone: the table fits again
        mujoco.mj_resetData(model, data)
        assert np.isfinite(_forces(model, data)).all()
    with pytest.raises(mjflex.ModelError, match="since this Flexures was built"):
        model.qpos0[0] += 0.05
        with flex:
            pass


def test_an_edit_between_two_forward_calls_is_seen(capfd):
    """Not only steps: mj_forward again at the same time (no step between) compares the model too."""
    model = two_body_spec(kind="plugin").compile()
    data = _stepped(model)
    mujoco.mj_forward(model, data)
    _move_element(model, [0.03, -0.02, 0.01])
    got = _forces(model, data)
    fresh = mujoco.MjData(model)
    fresh.qpos[:], fresh.qvel[:] = data.qpos, data.qvel
    np.testing.assert_array_equal(got, _forces(model, fresh))
    assert "was edited in place" in c_output(capfd)


@pytest.mark.parametrize("kind", ["record", "plugin"])
def test_the_queries_refuse_a_model_edited_in_place(kind):
    """Flexures' queries read its own table: after an in-place edit that changes the elements, they raise as install
    does (no pre-stress: build a new Flexures); an edit put back is accepted again."""
    model = two_body_spec(kind=kind).compile()
    flex = mjflex.Flexures(model)
    data = _stepped(model) if kind == "plugin" else mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    before = flex.wrenches(data)
    model.qpos0[0] += 0.05
    with pytest.raises(mjflex.ModelError, match=r"flex.model changed since this Flexures was built.*no pre-stress"):
        flex.wrenches(data)
    model.qpos0[0] -= 0.05
    np.testing.assert_array_equal(flex.wrenches(data), before)
    assert np.isfinite(mjflex.Flexures(model).wrenches(data)).all()
