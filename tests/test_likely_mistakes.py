"""What is likely a mistake is said once, where it was made (issue 24 items 4 and 6): damping ratios above 1, an
element in parallel with joints, divergence as a Python warning beside MuJoCo's log line, close names for unknown
names, the "geoms or inertias" hint only where it helps, one meaning of pos= (frame=), sites that keep their size
through a save and reload.
"""

import contextlib
import warnings

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import mjflex
from tests.helpers import c_output
from tests.models import B_DEMO, two_body_spec
from tests.robots import K_HAND, arm_spec

pytestmark = pytest.mark.usefixtures("clean_callback")


# ----------------------------------------------------------------------------- damping ratios above 1


def test_a_ratio_above_1_is_said_once_at_the_users_line_or_refused_under_strict():
    spec = arm_spec()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mjflex.make_compliant(spec, "hand", K_HAND, site="wrist", damping_ratio=10)
    mine = [w for w in caught if w.category is mjflex.LikelyMistakeWarning]
    assert len(mine) == 1 and mine[0].filename == __file__
    assert "damping_ratio = [10.0]: a ratio above 1 is overdamped" in str(mine[0].message)
    assert "10 % is 0.1" in str(mine[0].message)
    spec, before = arm_spec(), arm_spec().to_xml()
    with pytest.raises(ValueError, match=r"damping_ratio = \[10.0\].*strict=True refuses it"):
        mjflex.make_compliant(spec, "hand", K_HAND, site="wrist", damping_ratio=10, strict=True)
    assert spec.to_xml() == before
    model = spec.compile()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # 0.9 is legal and said nothing about
        compliance = mjflex.make_compliant(spec, "hand", K_HAND, site="wrist", damping_ratio=0.9)
    model = spec.compile()
    with pytest.warns(mjflex.LikelyMistakeWarning, match=r"damping_ratio = \[0.05, 0.05, 0.05, 0.05, 0.05, 2.0\]"):
        mjflex.damping_from_ratios(model, compliance.element, [0.05] * 5 + [2.0])
    with pytest.raises(ValueError, match="strict=True refuses it"):
        mjflex.damping_from_ratios(model, compliance.element, 2.0, strict=True)


# ----------------------------------------------------------------------------- elements in parallel with joints

HINGED = """<mujoco><worldbody><body name="base" pos="0 0 0.5"><geom size="0.05"/>
  <body name="arm" pos="0 0 0.1"><joint name="elbow" axis="0 1 0"/><joint name="twist" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/></body>
  <body name="glued" pos="0.1 0 0"><geom size="0.02"/></body></body>
  <body name="free" pos="1 0 0"><freejoint/><geom size="0.02"/></body></worldbody></mujoco>"""
K6 = [5, 5, 5, 1e4, 1e4, 1e4]


def test_an_element_between_hinged_or_welded_bodies_is_said_and_a_free_body_is_not():
    spec = mujoco.MjSpec.from_string(HINGED)
    with pytest.warns(mjflex.LikelyMistakeWarning) as record:
        mjflex.add_flexure(spec, "parallel", "base", "arm", pos=[0, 0, 0.6], K=K6)
    (w,) = (r for r in record if r.category is mjflex.LikelyMistakeWarning)
    assert w.filename == __file__
    assert "joint(s) elbow (hinge), twist (hinge) already join: the element acts in parallel with them, along the " \
           "2 degree(s) of freedom" in str(w.message)  # fmt: skip
    assert "mjflex.make_compliant(spec, 'arm', K, replace_joints=True)" in str(w.message)
    with pytest.warns(mjflex.LikelyMistakeWarning, match="body 'glued' is welded to its parent 'base'.*never deflects"):
        mjflex.add_flexure(spec, "welded", "glued", "base", pos=[0.1, 0, 0.5], K=K6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mjflex.add_flexure(spec, "grounded", "world", "free", pos=[1, 0, 0], K=K6)  # a free joint: the usual case


# ----------------------------------------------------------------------------- divergence, in Python


def _diverging(kind):
    model = two_body_spec(B=B_DEMO, integrator="Euler", timestep=0.5, kind=kind).compile()
    data = mujoco.MjData(model)
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    flex = mjflex.Flexures(model)
    return model, data, (flex if kind == "record" else contextlib.nullcontext())


def _divergence_warnings(caught):
    return [w for w in caught if w.category is mjflex.DivergenceWarning]


@pytest.mark.parametrize("kind", ["record", "plugin"])
def test_divergence_raises_a_python_warning_once_per_run_beside_the_log_line(kind, capfd):
    model, data, provided = _diverging(kind)
    with warnings.catch_warnings(record=True) as caught, provided:
        warnings.simplefilter("always")
        for _ in range(60):  # diverges again and again after MuJoCo's auto-resets
            mujoco.mj_step(model, data)
    (w,) = _divergence_warnings(caught)
    assert (w.message.element, w.message.model, w.message.time, w.message.step) == ("link", "two_body", 1.5, 3)
    assert w.filename == __file__  # the user's mj_step
    assert c_output(capfd).count("WARNING: mjflex: flexure 'link'") == 1  # MuJoCo's log line is still there
    mujoco.mj_resetData(model, data)  # a new run: warned again
    data.qvel[:] = np.random.default_rng(0).normal(size=model.nv)
    with warnings.catch_warnings(record=True) as caught, provided:
        warnings.simplefilter("always")
        for _ in range(4):
            mujoco.mj_step(model, data)
    assert len(_divergence_warnings(caught)) == 1


def test_the_warning_chains_to_a_handler_set_before_and_can_be_switched_off(capfd):
    """MuJoCo's legacy mju_user_warning (set by the user) still gets every message; divergence_warnings(False)
    leaves the log line alone."""
    received = []
    mujoco.set_mju_user_warning(received.append)
    try:
        model, data, _ = _diverging("plugin")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mujoco.mj_step(model, data, nstep=10)
        assert len(_divergence_warnings(caught)) == 1
        assert sum("mjflex: flexure 'link'" in m for m in received) == 1
    finally:
        mujoco.set_mju_user_warning(None)
    assert mjflex.divergence_warnings(False) is True
    try:
        model, data, _ = _diverging("plugin")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mujoco.mj_step(model, data, nstep=10)
        assert _divergence_warnings(caught) == []
        assert c_output(capfd).count("WARNING: mjflex: flexure 'link'") == 1
    finally:
        assert mjflex.divergence_warnings(True) is False


def test_rollout_threads_warn_without_harm():
    """mujoco.rollout steps in worker threads: the warning comes from there, and nothing breaks."""
    model, data, _ = _diverging("plugin")
    datas = [mujoco.MjData(model) for _ in range(2)]
    state = np.zeros((2, mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)))
    for i, d in enumerate(datas):
        d.qvel[:] = data.qvel
        mujoco.mj_getState(model, d, state[i], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        states, _ = rollout.rollout([model] * 2, datas, state, nstep=20)
    assert 1 <= len(_divergence_warnings(caught)) <= 2  # one per MjData run (the plugin's watch is per MjData)
    assert states.shape[:2] == (2, 20)


# ----------------------------------------------------------------------------- names, hints


def test_unknown_names_get_close_names_everywhere():
    spec = mujoco.MjSpec.from_string(HINGED)
    spec.body("arm").add_site(name="tip", pos=[0.3, 0, 0])
    cases = [
        (lambda: mjflex.add_flexure(spec, "e", "world", "fre", pos=[1, 0, 0], K=K6), r"'fre'.*did you mean \['free'"),
        (lambda: mjflex.add_flexure(spec, "e", "base", "arm", site="tipp", K=K6), r"'tipp'.*did you mean \['tip'\]"),
        (lambda: mjflex.add_flexure(spec, "e", "world", "free", pos=[0, 0, 0], frame="bse", K=K6),
         r"'bse'.*did you mean \['base'\]"),
        (lambda: mjflex.make_compliant(spec, "glue", K6), r"body 'glue' is not in the spec; did you mean \['glued'\]"),
        (lambda: mjflex.make_compliant(spec, "glued", K6, collide=["bas"]), r"'bas'.*did you mean \['base'\]"),
        (lambda: mjflex.make_compliant(spec, "glued", K6, pos=[0, 0, 0], frame="fre"), r"did you mean \['free'\]"),
    ]  # fmt: skip
    for call, message in cases:
        with pytest.raises(ValueError, match=message):
            call()
    mjflex.make_compliant(spec, "glued", K6, name="mount")
    model = spec.compile()
    with pytest.raises(KeyError, match=r"no flexure named 'mont'; did you mean \['mount'\]"):
        mjflex.damping_from_ratios(model, "mont", 0.02)


def test_the_geoms_or_inertias_hint_comes_only_with_a_mass_or_inertia_error():
    massless = mujoco.MjSpec.from_string('<mujoco><worldbody><body name="B"><freejoint/></body></worldbody></mujoco>')
    with pytest.raises(ValueError, match=r"(?s)mass and inertia.*add the bodies' geoms or inertias"):
        mjflex.add_flexure(massless, "e", "world", "B", pos=[0, 0, 0], K=K6)
    broken = mujoco.MjSpec.from_string(HINGED)
    broken.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1="elbo")
    with pytest.raises(ValueError, match="elbo") as raised:
        mjflex.add_flexure(broken, "e", "world", "free", pos=[1, 0, 0], K=K6)
    assert "geoms or inertias" not in str(raised.value)


# ----------------------------------------------------------------------------- pos= and frame=, site sizes


def test_frame_gives_pos_one_meaning_and_the_old_make_compliant_default_warns():
    spec = mujoco.MjSpec.from_string(HINGED)
    a = mjflex.add_flexure(spec, "in_base", "world", "free", pos=[0.1, 0, 0], frame="base", K=K6)
    b = mjflex.add_flexure_in_body_frame(spec, "same", "base", "free", pos=[0.1, 0, 0], K=K6)
    np.testing.assert_allclose(a.site_a.pos, [0.1, 0, 0.5])  # the world's site: base's frame moved by 0.5 m
    np.testing.assert_allclose(b.site_b.pos, a.site_b.pos)
    frames = []
    for frame, pos in (("parent", [0.1, 0, 0]), ("world", [0.1, 0, 0.5]), ("body", [0, 0, 0]), (None, [0.1, 0, 0])):
        s = mujoco.MjSpec.from_string(HINGED)
        context = pytest.warns(FutureWarning, match="frame='parent' to keep it") if frame is None else (
            contextlib.nullcontext())  # fmt: skip
        with context:
            c = mjflex.make_compliant(s, "glued", K6, pos=pos, frame=frame)
        frames.append(c.frame)
    for f in frames[1:]:
        np.testing.assert_allclose(f[0], frames[0][0], atol=1e-15)  # all the same frame, in the parent's
    assert frames[0][0] == (0.1, 0.0, 0.0)


def test_element_sites_keep_their_size_and_shape_through_a_save_and_reload():
    """A body's childclass with box-shaped sites: the element's sites stay 2 mm balls (round ellipsoids, whose three
    sizes MuJoCo writes), compiled and read back."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><default><default class="c"><site type="box" size="0.03 0.02 0.01" rgba="1 0 0 1"/></default>'
        '</default><worldbody><body name="A" childclass="c"><freejoint/><geom size="0.01"/></body>'
        '<body name="B" pos="0.1 0 0"><freejoint/><geom size="0.01"/></body></worldbody></mujoco>'
    )
    mjflex.add_flexure(spec, "e", "A", "B", pos=[0.05, 0, 0], K=K6)
    model = spec.compile()  # a box site of size (0.002, 0, 0) did not compile before
    again = mujoco.MjModel.from_xml_string(spec.to_xml())
    for m in (model, again):
        np.testing.assert_array_equal(m.site_size, [[0.002] * 3] * 2)
        assert (m.site_type == mujoco.mjtGeom.mjGEOM_ELLIPSOID).all()
