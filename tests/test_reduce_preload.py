"""mjflex.reduce keeps an element's preload: its rest pose (issue 31) through every form the reduction gives it.

An element turned into MuJoCo's joint springs rests where the element rested (``springref`` = ``qpos0`` plus the rest
pose's angle about the hinge's axis); a rest pose that the kept joints cannot reach keeps the element; a planar
record carries the rest pose and the stops into the plane. Each is judged by the static pose under gravity against
the full element model's (and, for the springs, against the rigid model's own joint spring with its springref).
"""

import warnings

import mujoco
import numpy as np
import pytest

import mjflex

#: A 1 kg arm on a hinge about y, held against gravity by a joint spring resting 0.3 rad away (a preload).
ARM = """<mujoco><compiler angle="radian"/><option timestep="0.002"/><worldbody>
<body name="arm" pos="0 0 0.5"><joint name="hinge" type="hinge" axis="0 1 0" {spring} damping="0.1"/>
<geom name="arm" type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="1"/></body></worldbody></mujoco>"""
#: A notch about the element z (the replaced hinge's axis), stiff in the five other directions.
K_NOTCH = [1e5, 1e5, 5.0, 1e6, 1e6, 1e6]


def _rest_geom(model, name="arm"):
    """World position [m] and rotation of geom ``name`` where ``model`` rests under gravity."""
    flex = mjflex.Flexures(model) if len(mjflex.Flexures(model)) else None
    data = mujoco.MjData(model)
    data.qpos[:] = mjflex.static_equilibrium(model, flex, tol=1e-11)
    mujoco.mj_kinematics(model, data)
    g = model.geom(name).id
    return data.geom_xpos[g].copy(), data.geom_xmat[g].reshape(3, 3).copy()


def _arm(rest=None, spring='stiffness="5" springref="0.3"'):
    """``(rigid, full)``: the arm with its hinge spring, and the hinge replaced by the notch (its springref carried
    over as the element's rest pose, or ``rest`` given)."""
    rigid = mujoco.MjSpec.from_string(ARM.format(spring=spring))
    full = mujoco.MjSpec.from_string(ARM.format(spring=spring))
    mjflex.make_compliant(full, "arm", K_NOTCH, replace_joints=True, name="notch", damping_ratio=0.05, rest=rest)
    return rigid.compile(), full


@pytest.mark.parametrize("given", [False, True])
def test_a_preloaded_notch_reduced_to_a_joint_spring_rests_where_the_full_model_does(given):
    """The notch's rest pose is a rotation about the hinge's axis (carried from the springref, or given): reduced
    at the file's step it is MuJoCo's spring on the hinge with springref = qpos0 + 0.3 rad, and the arm rests where
    the full element model and the rigid model's own spring put it."""
    angle = 0.3
    rest = ([0.0, 0.0, 0.0], [np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2)]) if given else None
    rigid, full_spec = _arm(rest, spring="" if given else 'stiffness="5" springref="0.3"')
    full = full_spec.compile()
    assert mjflex.Flexures(full).records[0].rest is not None  # the preload is the element's now
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        variant = mjflex.reduce(full_spec)
    m = variant.model
    assert not variant.has_flexures and m.nv == 1  # the hinge alone, MuJoCo's spring on it
    hinge = m.joint("hinge")
    assert hinge.stiffness[0] == pytest.approx(5.0, rel=1e-12)
    assert m.qpos_spring[hinge.qposadr[0]] == pytest.approx(m.qpos0[hinge.qposadr[0]] + angle, abs=1e-12)
    p_full, R_full = _rest_geom(full)
    p_red, R_red = _rest_geom(m)
    moved = np.linalg.norm(p_full - full.geom_pos[full.geom("arm").id] - full.body_pos[full.body("arm").id])
    assert moved > 0.01  # gravity and the preload move it
    sag = 9.81 * 1.0 / K_NOTCH[5]  # held rigid here, the full model's stiff translations sag m g / k (1e-5 m)
    assert np.linalg.norm(p_red - p_full) < 2 * sag < 1e-3 * moved
    assert np.abs(R_red - R_full).max() < 1e-6
    if not given:  # the rigid model's own joint spring with its springref: the same rest
        p_rigid, _ = _rest_geom(rigid)
        assert np.linalg.norm(p_red - p_rigid) < 1e-9
    assert max(s["relative"] for s in variant.details["statics"]) < 1e-3


def test_a_rest_pose_off_the_hinge_axis_keeps_the_element():
    """A rest pose turned off the hinge's axis is reached only by turning about all three axes: the notch is kept
    whole in a band (its static pose exact), and at the file's step the error names its rest pose."""
    axis = np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0])
    rest = ([0.0, 0.0, 0.0], [np.cos(0.15), *(np.sin(0.15) * axis)])
    _, full_spec = _arm(rest, spring="")
    variant = mjflex.reduce(full_spec, keep_below_hz=10.0)
    assert variant.details["elements"]["notch"]["kept"]
    assert variant.details["elements"]["notch"]["needed"]["rx"] == ["its rest pose"]
    p_full, _ = _rest_geom(full_spec.compile())
    p_red, _ = _rest_geom(variant.model)
    assert np.linalg.norm(p_red - p_full) < 1e-9
    with pytest.raises(ValueError, match=r"element 'notch', direction r[xy] \(needed by its rest pose\)"):
        mjflex.reduce(full_spec)


def _planar_block(rest_z=0.0):
    """A 1 kg block on a leaf in the x-y plane, gravity along -y: preloaded by a rest pose (0.1 rad about z, 2 mm
    along y; ``rest_z`` along z) and stopped at -5 mm along the leaf's y, where gravity presses it."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><option gravity="0 -9.81 0"/><worldbody><body name="block" pos="0.1 0 0"><freejoint/>'
        '<geom name="block" type="box" size="0.02 0.02 0.02" mass="1"/></body></worldbody></mujoco>'
    )
    rest = ([0.0, 0.002, rest_z], [np.cos(0.05), 0.0, 0.0, np.sin(0.05)])
    stops = mjflex.Stops(lower=[None, None, None, None, -0.005, None], upper=[None, None, 0.3, None, None, None])
    mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0.05, 0, 0], K=[1e3, 1e3, 2.0, 1e5, 1e3, 1e6], rest=rest,
                       stops=stops)  # fmt: skip
    return spec


@pytest.mark.parametrize("plane", ["auto", [0.0, 0.0, -1.0]])
def test_a_planar_record_keeps_the_rest_pose_and_the_stops(plane):
    """Reduced to a planar model, the leaf is a 3x3 record with its rest pose and its stops in the plane's
    coordinates (the stop engaged under gravity): the block rests where the full 3-D model puts it. With the normal
    against the element's z the plane's frame turns the element's y and rotations over: the stops change sides."""
    spec = _planar_block()
    variant = mjflex.reduce(spec, keep_below_hz=50.0, plane=plane)
    rec = mjflex.Flexures(variant.model).records[0]
    assert rec.planar and rec.rest is not None and rec.stops
    if plane == "auto":
        assert variant.details["plane"] == pytest.approx([0.0, 0.0, 1.0])
        assert rec.stops.lower == (-np.inf, -np.inf, -0.005) and rec.stops.upper == (0.3, np.inf, np.inf)
    else:
        assert rec.stops.lower == (-0.3, -np.inf, -np.inf) and rec.stops.upper == (np.inf, np.inf, 0.005)
    p_full, R_full = _rest_geom(spec.compile(), "block")
    p_red, R_red = _rest_geom(variant.model, "block")
    assert p_full[1] < -0.005  # pressed into the stop (its stiffness is 100 K_yy)
    assert np.linalg.norm(p_red - p_full) < 1e-9 and np.abs(R_red - R_full).max() < 1e-9


def test_a_rest_pose_out_of_the_plane_is_not_a_planar_scene():
    variant = mjflex.reduce(_planar_block(rest_z=0.001), keep_below_hz=50.0, plane="auto", verify=False)
    assert variant.details["plane"] is None
    assert "not planar (element 'leaf''s rest pose leaves the plane)" in variant.report


def test_the_band_is_measured_where_the_scene_rests():
    """The band (keep_below_hz) is linearized where the preloaded arm rests under gravity, as the step mode's: the
    full model's mode is the rigid model's own oscillation about that rest (its hinge spring, simulated undamped
    with RK4 at 1 ms for 3 s, from the zero crossings), within 0.5 % (at qpos0 unloaded it read 4 % low), and the
    reduced model's, at its own rest, within 0.1 % of it."""
    rigid, full_spec = _arm()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjflex.ReductionWarning)
        modes = mjflex.reduce(full_spec, keep_below_hz=50.0).details["modes"]
    rigid.dof_damping[:] = 0.0
    rigid.opt.integrator, rigid.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, 1e-3
    data = mujoco.MjData(rigid)
    data.qpos[:] = rest = mjflex.static_equilibrium(rigid, None)
    data.qvel[:] = 0.01
    swing = np.empty(3000)
    for i in range(swing.size):
        mujoco.mj_step(rigid, data)
        swing[i] = data.qpos[0] - rest[0]
    crossings = np.nonzero(np.diff(np.sign(swing)))[0]
    measured = (len(crossings) - 1) / (2 * (crossings[-1] - crossings[0]) * rigid.opt.timestep)
    assert modes["full_hz"][0] == pytest.approx(measured, rel=5e-3)
    assert modes["reduced_hz"][0] == pytest.approx(modes["full_hz"][0], rel=1e-3)
