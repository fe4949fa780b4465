"""Messages that tell the user what to do (issue 33 items 7 and 8): divergences point at the step advice; a name that
is not found gets the close names, and a name of another kind is said to be that."""

import contextlib

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.app.simulate import DivergenceError, simulate
from mjflex.mjcf import naming
from tests.spine import spine_spec

TWO_BODY = "models/two_body.xml"
ADVICE = "mjflex.step_advice(model) gives the largest stable one"


@pytest.mark.usefixtures("clean_callback")
@pytest.mark.parametrize("kind", ["record", "plugin"])
def test_divergence_messages_point_at_the_step_advice(kind):
    """Item 7: the C engine's report (both forms), the provider's non-finite query and the simulate run's message
    name mjflex.step_advice, which gives the step, not normal_modes (1.0.0), which gives frequencies."""
    spec = mujoco.MjSpec()
    spec.modelname = "light"
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4  # the callback's next evaluation is in the step
    body = spec.worldbody.add_body(name="B", pos=[0, 0, 0.5], mass=1e-6, inertia=[1e-12] * 3)
    body.explicitinertial = True
    body.add_freejoint()
    mjflex.add_flexure(spec, "spring", "world", "B", pos=[0, 0, 0.5], K=np.diag([1e-3] * 3 + [1e6] * 3), kind=kind)
    model = spec.compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qpos[0] += 0.02  # 2e10 m/s^2 on 1 mg: MuJoCo's bad-qacc check fires in the first step
    messages = []
    with flex if kind == "record" else contextlib.nullcontext():
        with pytest.raises(mujoco.FatalError, match="diverged in the step") as c_engine:
            mujoco.mj_step(model, data)
    messages.append(str(c_engine.value))
    data.qpos[0] = np.nan
    mujoco.mj_kinematics(model, data)  # the queries read the data as it is
    with pytest.raises(mujoco.FatalError, match="its wrench is not finite") as query:
        flex.wrenches(data)
    messages.append(str(query.value))
    plain = mujoco.MjModel.from_xml_path(TWO_BODY)
    flat = mjflex.Flexures(plain)
    flat.set_enabled("hinge", False)
    run = mujoco.MjData(plain)
    run.qvel[0] = 2e10
    with pytest.raises(DivergenceError) as simulated:
        simulate(plain, run, flat, 10 * plain.opt.timestep, progress=False)
    messages.append(str(simulated.value))
    for message in messages:
        assert ADVICE in message and "normal_modes" not in message, message


def _many_sites_spec(n=677):
    """The spine with ``n`` more sites named like a musculoskeletal model's (muscle path points)."""
    spec = spine_spec()
    body = spec.body("L3")
    for i in range(n):
        body.add_site(name=f"muscle{i // 4:03d}_r-P{i % 4 + 1}", pos=[0.001 * (i % 7), 0, 0])
    return spec


def test_a_site_typo_gets_the_close_names_not_the_first_ten_of_many():
    """Item 8: with 681 sites, a site given in another case or without its separators got the first 10 sites in 1.0.0
    (difflib, case- and separator-sensitive, found nothing close); now the close ones, and a name nothing is close
    to says so instead of listing 10 unrelated sites."""
    spec = _many_sites_spec()
    assert len(spec.sites) > 600
    K = np.diag([10.0] * 3 + [1e5] * 3)
    for typo in ("l3_TOP", "L3top", "l3-top"):
        with pytest.raises(ValueError, match=r"site '.*' is not a site of the spec; did you mean \['L3_top'\]\?$"):
            mjflex.add_flexure(spec, "e", "L4", "L3", site=typo, K=K)
    with pytest.raises(ValueError, match=r"did you mean \['muscle012_r-P3'"):
        mjflex.add_flexure(spec, "e", "L4", "L3", site="Muscle012_R_P3", K=K)
    with pytest.raises(ValueError, match=r"'zzz' is not a site of the spec \(none of its 681 sites has a close name"):
        mjflex.add_flexure(spec, "e", "L4", "L3", site="zzz", K=K)


def test_a_joint_given_for_a_body_says_whose_joint_it_is():
    """Item 8: a joint's name where a body is expected (make_compliant, add_flexure, a frame) says which body the joint
    moves; a body's name where a site is expected says it is a body."""
    spec = spine_spec()
    K = np.diag([10.0] * 3 + [1e5] * 3)
    joint = r"'L4_flex'.*; that is a joint of body 'L4', not a body$"
    with pytest.raises(ValueError, match=joint):
        mjflex.make_compliant(spec, "L4_flex", K, replace_joints=True)
    with pytest.raises(ValueError, match=joint):
        mjflex.add_flexure(spec, "e", "L5", "L4_flex", pos=[0, 0, 0], K=K)
    with pytest.raises(ValueError, match=r"'L3_top'.*; that is a site of body 'L3', not a body$"):
        mjflex.make_compliant(spec, "L3_top", K)
    with pytest.raises(ValueError, match=r"'L4'.*; that is a body, not a site$"):
        mjflex.add_flexure(spec, "e", "L5", "L4", site="L4", K=K)


def test_close_names_rules():
    names = ["L4_L5_site", "L3_top", "base", "T12-L1", "arm_upper"]
    assert naming.close_names("l4l5_SITE", names) == ["L4_L5_site"]  # case and separators
    assert naming.close_names("bse", names) == ["base"]  # difflib
    assert naming.close_names("upper", names) == ["arm_upper"]  # contained
    assert naming.close_names("qqq", names) == []
    assert naming.suggestion("qqq", names, "sites") == f" (its sites: {names})"  # few: all of them
    assert naming.suggestion("x", [], "sites") == ""
