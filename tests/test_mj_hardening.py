"""Nothing lost silently: sleeping trees, composed models, near-miss names, bad input, tolerances, divergence."""

import json
import warnings

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import c_output
from tests.models import B_DEMO, K_DEMO, push_after_rest, two_body_spec
from tests.test_mj_model_errors import K6, _model

pytestmark = pytest.mark.usefixtures("clean_callback")


# ------------------------------------------------------------------ 3. sleeping


def test_sleeping_trees_joined_by_an_element_move_exactly_as_without_sleep():
    """MuJoCo ignores forces on sleeping trees; joined trees must therefore stay awake, like
    trees coupled by stiff tendons. Pushing A must drag B exactly as with sleeping disabled."""
    awake = push_after_rest(two_body_spec(B=B_DEMO, integrator="Euler").compile())
    spec = two_body_spec(B=B_DEMO, integrator="Euler")
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    model = spec.compile()
    got = push_after_rest(model)
    assert np.array_equal(got, awake)
    assert np.abs(got[-1, 6:9]).max() > 0.1  # B moves
    linear = got[:, 0:3] * 1.3 + got[:, 6:9] * 0.8  # masses of A and B: the push's momentum is shared
    assert np.allclose(linear, linear[0], rtol=0, atol=1e-12 * np.abs(linear[0]).max())
    assert (model.tree_sleep_policy == mujoco.mjtSleepPolicy.mjSLEEP_AUTO_NEVER).all()


def test_explicitly_sleepy_tree_warns_at_install():
    spec = two_body_spec(B=B_DEMO, integrator="Euler")
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    spec.body("B").sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    flex = mjflex.Flexures(spec.compile())
    with pytest.warns(UserWarning, match=r"flexure 'link' joins tree 'B'.*a passive callback cannot wake it"):
        flex.install()


# ------------------------------------------------------------------ 4. composed models, dm_control spelling


def test_attached_specs_keep_their_elements_under_prefix_and_suffix():
    alone = two_body_spec(B=B_DEMO).compile()
    parent = mujoco.MjSpec()
    parent.option.gravity = [0, 0, 0]
    parent.option.timestep, parent.option.integrator = alone.opt.timestep, alone.opt.integrator
    for prefix, suffix in [("robot1-", ""), ("robot2-", "-r")]:
        parent.attach(two_body_spec(B=B_DEMO), prefix=prefix, suffix=suffix, frame=parent.worldbody.add_frame())
    model = parent.compile()
    flex = mjflex.Flexures(model)
    assert flex.names == ("robot1-link", "robot2-link-r")
    data, ref = mujoco.MjData(model), mujoco.MjData(alone)
    rng = np.random.default_rng(0)
    ref.qvel[:] = rng.normal(size=alone.nv)
    data.qvel[:] = np.tile(ref.qvel, 2)
    with flex, mjflex.Flexures(alone):
        for _ in range(300):
            mujoco.mj_step(model, data)
            mujoco.mj_step(alone, ref)
    for robot in range(2):  # each robot moves as the model alone (forces of both elements applied)
        assert np.array_equal(data.qpos[14 * robot : 14 * robot + 14], ref.qpos)
    assert flex.set_enabled("robot2-link-r", False) is None and flex.enabled.tolist() == [True, False]


DM_CONTROL_XML = """
<mujoco model="arena">
  <default>
    <default class="/"/>
    <default class="arm/"/>
  </default>
  <worldbody>
    <body name="arm/">
      <body name="arm/A">
        <geom name="arm//unnamed_geom_0" class="arm/" size="0.050000000000000003"/>
        <site name="arm/hinge.a" class="arm/" pos="0.050000000000000003 0 0"/>
      </body>
      <body name="arm/B" pos="0.10000000000000001 0 0">
        <joint name="arm//unnamed_joint_0" class="arm/" type="hinge" pos="-0.050000000000000003 0 0" axis="0 0 1"/>
        <geom name="arm//unnamed_geom_1" class="arm/" size="0.050000000000000003"/>
        <site name="arm/hinge.b" class="arm/" pos="-0.050000000000000003 0 0"/>
      </body>
    </body>
  </worldbody>
  <custom>
    <text name="arm/mjflex:hinge" data="{&quot;mjflex&quot;: 1, &quot;K&quot;: [1, 1, 1, 1000, 1000, 1000]}"/>
  </custom>
</mujoco>
"""


def test_dm_control_spelling():
    """dm_control's mjcf rejects '/' in names but accepts sites 'hinge.a', 'hinge.b', and scopes
    every name of an attached model with 'arm/'. The XML above is what dm_control 1.0.50 wrote
    (``arena.attach(arm); arena.to_xml_string()``) for a model 'arm' with those sites and the
    record 'mjflex:hinge'; its own Physics does not load under MuJoCo 4.0, mujoco does."""
    model = mujoco.MjModel.from_xml_string(DM_CONTROL_XML)
    with pytest.warns(UserWarning, match=r"'arm/A' and 'arm/B' joined by flexure 'arm/hinge' are\s+in contact"):
        flex = mjflex.Flexures(model)  # the two boxes of that model overlap at the hinge and nothing excludes them
    assert flex.names == ("arm/hinge",)
    data = mujoco.MjData(model)
    data.qpos[0] = 0.1
    mujoco.mj_forward(model, data)
    assert np.isclose(flex.wrenches(data)[0, 2], -0.1, rtol=1e-14)  # the hinge's K_rz = 1 N m/rad acts
    assert [mujoco.mj_id2name(flex.model, mujoco.mjtObj.mjOBJ_SITE, s) for s in flex.site_ids[0]] == [
        "arm/hinge.a",
        "arm/hinge.b",
    ]
    both = DM_CONTROL_XML.replace('<site name="arm/hinge.a"', '<site name="arm/hinge/a"/><site name="arm/hinge.a"')
    both = both.replace('<site name="arm/hinge.b"', '<site name="arm/hinge/b"/><site name="arm/hinge.b"')
    with pytest.raises(mjflex.ModelError, match=r"keep one spelling"):
        mjflex.Flexures(mujoco.MjModel.from_xml_string(both))


# ------------------------------------------------------------------ 5. nothing silently ignored


@pytest.mark.parametrize("name", ["mjflx:e", "MJFLEX:e", "mjflex-e", "robot/mjflex_e"])
def test_near_miss_record_names_warn(name):
    spec = mujoco.MjSpec.from_string(_model_xml())
    spec.text("mjflex:e").name = name
    with pytest.warns(UserWarning) as caught:
        flex = mjflex.Flexures(spec.compile())
    messages = [str(w.message) for w in caught]
    assert any(f"text record '{name}' looks like a flexure record" in m for m in messages)
    assert any("sites of an element 'e' have no text record 'mjflex:e'" in m for m in messages)
    assert len(flex) == 0


def _model_xml():
    from tests.test_mj_model_errors import TEMPLATE

    data = json.dumps({"mjflex": 1, "K": K6})
    return TEMPLATE.format(site_a="e/a", site_b="e/b", pos_b="-0.05 0 0", quat_b="", extra_a="", data=data)


def test_sites_without_record_warn():
    spec = mujoco.MjSpec.from_string(_model_xml())
    spec.delete(spec.text("mjflex:e"))
    with pytest.warns(UserWarning, match=r"sites of an element 'e' have no text record 'mjflex:e'"):
        mjflex.Flexures(spec.compile())


@pytest.mark.parametrize("bad", [None, "model.xml", "data"])
def test_not_a_model_is_a_type_error(bad):
    model = _model()
    arg = mujoco.MjData(model) if bad == "data" else bad
    with pytest.raises(TypeError, match=r"Flexures expects a mujoco.MjModel; got"):
        mjflex.Flexures(arg)


def test_data_of_another_model():
    flex = mjflex.Flexures(_model())
    spec = mujoco.MjSpec.from_string(_model_xml())
    spec.worldbody.add_body(name="static", pos=[0, 0, 1]).add_geom(size=[0.1, 0, 0])  # same nq, nsite: one body more
    other = spec.compile()
    with pytest.raises(ValueError, match=r"data belongs to another model: \(nq, nv, nbody, nsite\)"):
        flex.wrenches(mujoco.MjData(other))
    with pytest.raises(TypeError, match=r"expected a mujoco.MjData"):
        flex.potential_energy(flex.model)


def test_deeply_nested_json_is_a_model_error():
    deep = "[" * 100_000 + "]" * 100_000
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*nests JSON arrays or objects too deeply"):
        mjflex.Flexures(_model(data='{"mjflex": 1, "K": ' + deep + "}"))


@pytest.mark.parametrize("value", [1e300, 1.7e308])
def test_huge_stiffness_is_rejected_at_construction(value):
    K = list(K6)
    K[3] = value
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*K\[3, 3\] = .* is beyond 1e\+280"):
        mjflex.Flexures(_model(K=K))
    with pytest.raises(ValueError, match=r"flexure 'x': K\[3, 3\] = .* is beyond"):
        mjflex.add_flexure(two_body_spec(), "x", "A", "B", pos=[0.1, 0.02, 0.5], K=K)


def test_site_moved_after_construction_is_reported_at_install():
    """mjflex has no pre-stress: an element is unstressed at the pose its sites had when built."""
    model = two_body_spec(B=B_DEMO).compile()
    flex = mjflex.Flexures(model)
    model.site_pos[flex.site_ids[0, 1]] += [0.01, 0.0, 0.0]
    moved = r"flex.model changed since this Flexures was built: flexure 'link': sites 'link/a' and 'link/b' are 0.01 m"
    with pytest.raises(mjflex.ModelError, match=moved + r".*no pre-stress"):
        flex.install()
    assert not flex.installed


# ------------------------------------------------------------------ 6. tolerances


def test_coincidence_tolerance_is_the_elements_own_scale():
    """5 cm of mismatch near the origin must not pass because another body is 1e4 m away."""
    far = '<body name="far" pos="1e4 0 0"><geom size="1"/></body>'
    with pytest.raises(mjflex.ModelError, match=r"are 0.05 m apart .*tolerance 2.5e-06 m: 1e-05 times the 0.25 m"):
        mjflex.Flexures(_model(pos_b="-0.1 0 0", extra_a=far))


def test_element_far_from_origin_survives_a_saved_file(tmp_path):
    """Far from the origin the 6-digit rounding of positions is large, and so is the tolerance."""
    spec = two_body_spec(B=B_DEMO)
    for body in spec.bodies[1:]:
        body.pos = body.pos + [1234.5678, 0, 0]
    spec.delete(spec.text("mjflex:link"))
    for s in list(spec.sites):
        spec.delete(s)
    mjflex.add_flexure(spec, "link", "A", "B", pos=[1234.6678, 0.02, 0.5], quat=[0.8, 0, 0.6, 0], K=K_DEMO, B=B_DEMO)
    path = tmp_path / "far.xml"
    path.write_text(spec.to_xml())
    again = mujoco.MjModel.from_xml_path(str(path))
    flex = mjflex.Flexures(again)
    data = mujoco.MjData(again)
    mujoco.mj_forward(again, data)
    assert np.abs(flex.wrenches(data)).max() <= 1e-12


def test_float32_rotations_orthonormal_to_their_precision_are_accepted():
    R = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
    R32 = R.astype(np.float32)
    got = mjflex.twist_from_transform(R32, np.zeros(3, np.float32))
    # float32's rounding of R (epsilon 1.2e-7) bounds the error; achieved 5e-9 for this R
    assert np.allclose(got, mjflex.twist_from_transform(R, np.zeros(3)), rtol=0, atol=1.2e-7)
    with pytest.raises(ValueError, match=r"is not a rotation matrix: .*dtype float32.*in float64"):
        mjflex.twist_from_transform((R * 1.001).astype(np.float32), np.zeros(3))


# ------------------------------------------------------------------ 8. divergence with auto-reset on


def test_divergence_with_auto_reset_names_element_time_and_step(capfd):
    model = two_body_spec(B=B_DEMO, integrator="Euler", timestep=0.5).compile()  # far beyond 2/omega_max
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    with mjflex.Flexures(model), warnings.catch_warnings():
        for _ in range(10):
            mujoco.mj_step(model, data)  # no exception: MuJoCo's auto-reset is on
    out = c_output(capfd)
    # the step that starts at 1.5 s, where MuJoCo's own check fires ("Time = 1.5000"); the convention of every
    # mjflex message (mjflex.runtime.divergence), no longer "at time 1.5 s (step 3)"
    assert (
        "WARNING: mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 1.5 s (step index 3, "
        "counting from 0): MuJoCo found a bad qacc" in out
    )
    assert "WARNING: Nan, Inf or huge value in QACC" in out  # then MuJoCo's own handling: reset
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number >= 1 and data.time < 10 * 0.5


# ------------------------------------------------------------------ named per-element results


def test_table_labels_every_per_element_result():
    from tests.models import hinge_chain_spec

    model = hinge_chain_spec(n=4, B=B_DEMO).compile()
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(1).normal(size=model.nv)
    # deflected (at qpos0 the elements are exactly unstressed: energy 0, not round-off)
    mujoco.mj_integratePos(model, data.qpos, data.qvel, 0.01)
    mujoco.mj_forward(model, data)
    flex = mjflex.Flexures(model)
    flex.set_enabled("flex2", False)
    table = flex.results(data)
    assert table.dtype.names == ("name", "wrench", "displacement", "energy", "power", "enabled", "method")
    assert table["name"].tolist() == ["flex1", "flex2", "flex3"] and table["enabled"].tolist() == [True, False, True]
    assert np.array_equal(table["wrench"], flex.wrenches(data))
    assert np.array_equal(table["displacement"], flex.displacements(data))
    assert np.array_equal(table["energy"], flex.potential_energies(data))
    assert np.array_equal(table["power"], flex.dissipation_powers(data))
    row = table[table["name"] == "flex3"][0]
    assert row["energy"] > 0 and row["power"] > 0 and row["method"] == "twist"


def test_large_but_allowed_entries_are_still_checked_for_symmetry():
    K = np.diag([1e270] * 6)
    K[0, 1] = 1e269  # sqrt(K_00 K_11) overflows float64: the scale must be formed without it
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*K is not symmetric: K\[0, 1\] = 1e\+269"):
        mjflex.Flexures(_model(K=K.tolist()))
