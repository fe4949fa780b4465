"""Robot models and measurements for the tests of compliant parts (mjflex.make_compliant).

* :func:`arm_spec`: a small arm built here: three hinged links held by position servos, and a
  hand welded to the last link whose "cuff" reaches back over the joint and overlaps the link
  before (the situation of a Robotiq 2F-85 on a UR5e, whose mount touches ``wrist_2_link``):
  MuJoCo filters that contact while the hand is welded, and collides it once the hand has joints.
* :func:`pusher_path`: gymnasium's 7-dof ``pusher.xml``, loaded unmodified from the installed
  package (a real robot file from PyPI).
* :func:`solve_statics` (Newton on chosen dofs, the forces of ``mj_forward`` and the provider) and
  :func:`subtree_wrench` (the load on a subtree about a frame, from masses and positions alone),
  :func:`decay_ratio` (a free vibration's logarithmic decrement).
* :func:`servo_held_arm` (the arm with its servo-held last joint replaced by an element, at its
  operating pose), :func:`arm_advice` (its step advice there, without the servo, unloaded),
  :func:`muscle_elbow` (a forearm on a compliant elbow held by two co-contracting muscles and a damper,
  at its operating pose) and :func:`knock_grows` (does a small knock on a run from a state grow?),
  the models and the check of the advised time step: used by tests/test_operating_pose.py,
  tests/test_step_advice.py and scripts/operating_pose.py, which records the figures of the how-to.
"""

import importlib.util
import os
import warnings

import mujoco
import numpy as np

import mjflex
from mjflex.analysis.linearize import state

ARM = """<mujoco model="arm">
  <compiler angle="radian"/>
  <option timestep="1e-4" integrator="RK4"/>
  <default>
    <default class="arm">
      <joint damping="0.5" armature="0.01" range="-3 3" limited="true" stiffness="2" frictionloss="0.1"/>
      <geom density="1000"/>
    </default>
  </default>
  <worldbody>
    <geom name="base" type="cylinder" size="0.05 0.05" pos="0 0 0.05"/>
    <body name="link1" pos="0 0 0.1" childclass="arm">
      <joint name="j1" axis="0 0 1"/>
      <geom name="g1" type="capsule" fromto="0 0 0.04 0 0 0.3" size="0.03"/>
      <body name="link2" pos="0 0 0.3">
        <joint name="j2" axis="0 1 0"/>
        <geom name="g2" type="capsule" fromto="0 0 0 0.3 0 0" size="0.025"/>
        <body name="link3" pos="0.3 0 0">
          <joint name="j3" axis="0 1 0"/>
          <geom name="g3" type="capsule" fromto="0 0 0 0.06 0 0" size="0.015"/>
          <site name="wrist" pos="0.06 0 0" quat="0.7071068 0 0.7071068 0"/>
          <body name="hand" pos="0.06 0 0">
            <geom name="palm" type="box" pos="0.05 0 0" size="0.04 0.03 0.015"/>
            <geom name="cuff" type="sphere" pos="-0.06 0 0" size="0.03"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="a1" joint="j1" kp="20000"/>
    <position name="a2" joint="j2" kp="20000"/>
    <position name="a3" joint="j3" kp="5000"/>
  </actuator>
  <keyframe>
    <key name="home" qpos="0.3 -0.5 0.8" ctrl="0.3 -0.5 0.8"/>
    <key name="up" qpos="-0.2 -1.2 0.4" ctrl="-0.2 -1.2 0.4"/>
  </keyframe>
</mujoco>"""

#: The arm's hand element: bending (about the element x, y axes), torsion (about z, along the
#: last link), three translations.
K_HAND = np.array([5.0, 5.0, 3.0, 2e4, 2e4, 2e4])
ARM_JOINTS = ("j1", "j2", "j3")


def arm_spec() -> mujoco.MjSpec:
    return mujoco.MjSpec.from_string(ARM)


def pusher_path() -> str:
    """gymnasium's pusher arm, as the package ships it."""
    root = importlib.util.find_spec("gymnasium").submodule_search_locations[0]
    return os.path.join(root, "envs", "mujoco", "assets", "pusher.xml")


def body_id(model, name) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)


def solve_statics(model, flex, data, dofs, tol=1e-8, iterations=30):
    """Equilibrium of the dofs ``dofs`` (others held as in ``data``), at zero velocity, in place.

    Newton's method on the residual ``qfrc_smooth`` of ``mj_forward`` with the elements' forces in
    it (MuJoCo's applied, actuator, passive and bias forces; plugin elements add theirs, text
    records while ``flex`` is installed; contacts disabled), its Jacobian by central
    differences; converged when the residual is ``tol`` times its scale (the round-off of stiff
    elements: 3e8 N/m times 1e-16 of the positions is ~1e-8 N).
    """
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    dofs = np.asarray(dofs)

    def residual(q):
        data.qpos[:], data.qvel[:] = q, 0.0
        with flex:
            mujoco.mj_forward(model, data)
        return data.qfrc_smooth[dofs].copy()

    q = data.qpos.copy()
    scale = np.abs(residual(q)).max() + 1e-300
    for _ in range(iterations):
        r = residual(q)
        if np.abs(r).max() < tol * scale:
            break
        G = np.zeros((len(dofs), len(dofs)))
        for j, dof in enumerate(dofs):
            cols = []
            for sign in (1.0, -1.0):
                qq = q.copy()
                dq = np.zeros(model.nv)
                dq[dof] = sign * 1e-7
                mujoco.mj_integratePos(model, qq, dq, 1.0)
                cols.append(residual(qq))
            G[:, j] = (cols[0] - cols[1]) / 2e-7
        dq = np.zeros(model.nv)
        dq[dofs] = -np.linalg.solve(G, r)
        mujoco.mj_integratePos(model, q, dq, 1.0)
    else:
        raise AssertionError(f"statics did not converge: residual {np.abs(r).max():.3g} (scale {scale:.3g})")
    residual(q)
    return data


def subtree_wrench(model, data, body, site, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
    """Load on the subtree of ``body`` about site ``site``, in the site's axes: ``[moment; force]``.

    Gravity on every body of the subtree (``body_mass``, ``xipos``) plus a wrench applied to
    ``body`` at its centre of mass (world axes): what an element at the site must carry.
    """
    root = body_id(model, body)
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    p, R = data.site_xpos[sid], data.site_xmat[sid].reshape(3, 3)
    moment, total = np.zeros(3), np.zeros(3)
    for b in range(model.nbody):
        chain = b
        while chain not in (0, root):
            chain = model.body_parentid[chain]
        if chain != root:
            continue
        f = model.body_mass[b] * model.opt.gravity
        moment += np.cross(data.xipos[b] - p, f)
        total += f
    moment += np.cross(data.xipos[root] - p, force) + np.asarray(torque)
    total += force
    return np.concatenate([R.T @ moment, R.T @ total])


def decay_ratio(y):
    """Damping ratio of a free vibration ``y(t)`` from its positive peaks (logarithmic decrement), and
    the number of periods it spans."""
    i = np.nonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:]) & (y[1:-1] > 0))[0] + 1
    peaks = y[i]
    n = len(peaks) - 1
    delta = np.log(peaks[0] / peaks[-1]) / n
    return delta / np.sqrt(4 * np.pi**2 + delta**2), n


def free_vibration(model, flex, element, dofs, mode, keyframe=None, periods=8.0, omega=None, amplitude=1e-3):
    """Element displacement along a mode in a free vibration started with velocity ``amplitude * mode``
    on ``dofs`` (from ``keyframe``, at rest otherwise): ``y(t) = x(t) . psi``, ``psi = J mode``."""
    from mjflex.analysis.damping import displacement_jacobian
    from mjflex.analysis.linearize import state

    base = state(model, keyframe)
    psi = displacement_jacobian(model, flex, element, base)[:, dofs] @ mode
    data = mujoco.MjData(model)
    if keyframe is not None:
        mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe))
    data.qvel[:] = 0.0
    data.qvel[dofs] = amplitude * mode
    e = flex.index(element)
    y = np.empty(int(periods * 2 * np.pi / omega / model.opt.timestep))
    with flex:
        for t in range(len(y)):
            mujoco.mj_step(model, data)
            y[t] = flex.displacements(data)[e] @ psi
    return y


#: The servo-held arm's j3 replaced by an element soft in bending and torsion (rx, ry: 100 N m/rad), stiffer about
#: j3 (rz, the hinge's axis: 300 N m/rad): its servo (a3, kp 5000) makes the mode about j3 the stiffest. Keyframe
#: "level": the servo's target is the element's rest (no preload).
K_WRIST = [100.0, 100.0, 300.0, 2e4, 2e4, 2e4]


def servo_held_arm(integrator):
    """``(model, flex, qpos)``: the arm (``integrator``: ``"Euler"`` or ``"RK4"``) with keyframe ``"level"`` and its
    link3 made compliant (``K_WRIST``, ``replace_joints=True``: j3 and its servo a3 stay, on the element's
    rotation), and its operating pose, the static equilibrium of ``"level"`` under gravity and the servos. j3 has
    no armature here (replace_joints keeps a joint's armature; 0.01 kg m^2 would make the mode about j3 slower than
    the element's bending, and the servo would no longer set the step)."""
    spec = arm_spec()
    spec.joint("j3").armature = 0.0
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.add_key(name="level", qpos=[0.3, -0.5, 0.0], ctrl=[0.3, -0.5, 0.0])
    with warnings.catch_warnings():  # K_WRIST is stiffer about j3 than in bending, on purpose (a wrist held by a3)
        warnings.simplefilter("ignore", mjflex.LikelyMistakeWarning)
        mjflex.make_compliant(spec, "link3", K_WRIST, replace_joints=True)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    return model, flex, mjflex.static_equilibrium(model, flex, keyframe="level")


def arm_advice(model, flex, qpos):
    """:func:`mjflex.step_advice` for :func:`servo_held_arm`, by name: ``"operating"`` at its operating pose ``qpos``
    with everything that holds it there (the defaults: gravity, the servos' stiffness, the springs),
    ``"without_servo"`` there without the servos' stiffness, ``"reference"`` at the unloaded ``qpos0`` (no
    gravity, servos or springs)."""
    return {
        "operating": mjflex.step_advice(model, flex, keyframe="level", qpos=qpos),
        "without_servo": mjflex.step_advice(model, flex, keyframe="level", qpos=qpos, actuator_stiffness=False),
        "reference": mjflex.step_advice(model, flex, gravity=False, actuator_stiffness=False, joint_springs=False),
    }


#: A forearm on an elbow hinge (replaced by an element in :func:`muscle_elbow`), two co-contracting muscles on the
#: elbow (MuJoCo's ``<muscle>``: force-length and force-velocity, activation dynamics; their length range given, the
#: joint's range times the gear, so that the compiler does not simulate to find it) and a ``<damper>``.
MUSCLE_ELBOW = """<mujoco model="elbow">
  <option timestep="1e-3"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
      <body name="forearm">
        <joint name="elbow" axis="0 1 0" range="-1.5 1.5" limited="true"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      </body>
    </body>
  </worldbody>
  <contact><exclude body1="upper" body2="forearm"/></contact>
  <actuator>
    <muscle name="flexor" joint="elbow" gear="0.05" force="1000" lengthrange="-0.075 0.075"/>
    <muscle name="extensor" joint="elbow" gear="-0.05" force="1000" lengthrange="-0.075 0.075"/>
    <damper name="damper" joint="elbow" kv="1" ctrlrange="0 1"/>
  </actuator>
</mujoco>"""
#: The elbow element: soft about the hinge axis (element z, a replaced hinge's axis), stiffer in the other directions.
K_ELBOW = [200.0, 200.0, 50.0, 2e5, 2e5, 2e5]
#: The muscles' and the damper's commands at the operating pose: half activation each, the damper at 1 N m s/rad.
ELBOW_CTRL = (0.5, 0.5, 1.0)


def muscle_elbow(integrator, ctrl=ELBOW_CTRL):
    """``(model, flex, qpos)``: :data:`MUSCLE_ELBOW` (``integrator``: MuJoCo's name) with its elbow replaced by an
    element (``K_ELBOW``, ``replace_joints=True``: the hinge stays, the muscles act on it), and its operating pose:
    the static equilibrium under gravity and ``ctrl`` (activations at their steady state, ``act = ctrl``)."""
    spec = mujoco.MjSpec.from_string(MUSCLE_ELBOW)
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    mjflex.make_compliant(spec, "forearm", K_ELBOW, replace_joints=True)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    return model, flex, mjflex.static_equilibrium(model, flex, ctrl=ctrl)


#: A knock grows when the knocked run departs from the unknocked one by this factor of the knock.
GROWTH = 1e3


def knock_grows(model, qpos, timestep, steps=3000, *, keyframe=None, ctrl=None, xfrc_applied=None, knock=1e-6):
    """Two runs of ``steps`` steps of ``timestep`` [s] from ``qpos`` at rest, one knocked on every dof (``knock``
    times a standard normal velocity, seed 0 [m/s, rad/s]), with the controls of ``keyframe`` or ``ctrl``
    (activations at their steady state) and the load ``xfrc_applied`` (nbody, 6): does their difference in velocity
    grow beyond ``GROWTH`` times the knock (or either run leave its bounds)? A bounded chatter (an element leaving
    and hitting its stop) grows too. ``model.opt.timestep`` is restored; mjflex's DivergenceWarning is silenced."""
    saved = model.opt.timestep
    model.opt.timestep = timestep
    try:
        runs = []
        for size in (0.0, knock):
            data = state(model, keyframe, qpos, ctrl)
            data.qvel[:] = size * np.random.default_rng(0).normal(size=model.nv)
            if xfrc_applied is not None:
                data.xfrc_applied[:] = xfrc_applied
            runs.append(data)
        start = np.linalg.norm(runs[1].qvel)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mjflex.DivergenceWarning)
            for _ in range(steps):
                for data in runs:
                    mujoco.mj_step(model, data)
                apart = np.linalg.norm(runs[1].qvel - runs[0].qvel)
                bad = any(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number for d in runs)
                if bad or not apart <= GROWTH * start:
                    return True
        return False
    finally:
        model.opt.timestep = saved
