"""Three robot scenes with compliant parts, for the reduction to the file's own time step (mjflex.reduce).

Each scene is ``(rigid spec, full spec, info)``: the robot as its file has it, and the same robot with its
compliant parts made elements by :func:`mjflex.make_compliant` (``replace_joints=True``); ``info`` gives the
controls of the scene's actuated run (``ctrl(t)``) and the keyframe that holds its loads.

* :func:`gripper`: a parallel gripper whose fingers are closed four-bars (parallelograms: a driver and a
  follower on the palm, a coupler carrying the pad, closed by a ``connect`` equality), driven by one position
  actuator on a tendon over both drivers (their mirror tied by a joint equality), on a lifting slide; its four
  passive pivots (the followers' and the couplers' hinges, armature 1e-3 kg m^2 as a Robotiq 2F-85's) become
  steel notch hinges from :func:`mjflex.geometry.notch_hinge_stiffness`. Built here: the public 2F-85 files on
  PyPI ship in robosuite, whose dependencies (numba, opencv, pynput, a pinned mink) the test extra does not take.
* :func:`spine`: the lumbar spine of ``tests/spine.py`` (three hinges per level, joint equalities tying the
  levels to L5, a fixed tendon, motors, a servo), at the 2 ms implicitfast step, with vertebrae of 0.1 kg and
  facet armature 1e-3 kg m^2, two muscles on tendons over the flexion and bending hinges, and L3's hinges
  replaced by a disc of literature stiffness.
* :func:`pusher_wrist`: gymnasium's pusher arm as the package ships it (10 ms, Euler), its wrist flexion made a
  compliant wrist (a series-elastic flexure, soft about the flexion axis).

The library's defaults for ``replace_joints`` are the scenes': the replaced joints keep their armature, their
ranges stay MuJoCo's joint limits (``stops="limits"``: constraints with the file's ``solref``, stable at its step),
and a lone replaced hinge's axis is the element's z. Two scenes say more than that, on purpose:

* the gripper places each notch's frame itself (:func:`_hinge_frame`): z along the pivot's axis, as the default, but
  x along the finger link, the notch's beam axis in :mod:`mjflex.geometry` (the default x, the body axis most nearly
  perpendicular to the hinge, is the body's y here, across the link);
* the pusher's wrist turns its range into element stops (``stops="element"``): the scene that tests the element's
  stops through a reduction (kept as the element in the stopped direction).
"""

import math

import mujoco
import numpy as np

import mjflex
from mjflex.geometry import notch_hinge_stiffness
from tests.robots import pusher_path
from tests.spine import spine_xml

#: Steel notch hinges (R, t, b [m], E [Pa], nu) for the gripper's pivots.
NOTCH = dict(R=2e-3, t=0.4e-3, b=6e-3, E=200e9, nu=0.3)
PIVOT_ARMATURE = 1e-3
#: The pivots' reference angle [rad] (their value at the modelled pose: the notches rest there).
PIVOT_REF = 0.05

GRIPPER = """<mujoco model="four-bar gripper">
  <compiler angle="radian"/>
  <option timestep="0.002" integrator="implicitfast"/>
  <default>
    <joint damping="0.05"/>
    <geom density="2700" friction="1 0.05 0.001"/>
    <default class="pivot"><joint type="hinge" axis="1 0 0" armature="{arm}" damping="0.002" ref="{ref}"/></default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.03"><freejoint name="box"/><geom type="box" size="0.02 0.02 0.03" density="300"/></body>
    <body name="palm" pos="0 0 0.25">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.2 0.2" damping="20"/>
      <geom type="box" size="0.03 0.05 0.02"/>
      {fingers}
    </body>
  </worldbody>
  <tendon><fixed name="split"><joint joint="left_driver" coef="0.5"/><joint joint="right_driver" coef="0.5"/></fixed>
  </tendon>
  <equality>
    <joint name="mirror" joint1="right_driver" joint2="left_driver"/>
    <connect name="left_loop" body1="left_coupler" body2="left_follower" anchor="0 0.02 0"/>
    <connect name="right_loop" body1="right_coupler" body2="right_follower" anchor="0 -0.02 0"/>
  </equality>
  <actuator>
    <position name="fingers" tendon="split" kp="40" ctrlrange="0 0.6"/>
    <position name="lifter" joint="lift" kp="2000" ctrlrange="-0.2 0.2"/>
  </actuator>
  <sensor><jointpos name="left_angle" joint="left_driver"/><framepos name="box_pos" objtype="body" objname="box"/>
  </sensor>
  <keyframe><key name="open" qpos="0 0 0.03 1 0 0 0 0 0 {ref} {ref} 0 {ref} {ref}" ctrl="0 0.01"/></keyframe>
</mujoco>"""

FINGER = """<body name="{s}_driver" pos="0 {y} -0.02">
        <joint name="{s}_driver" axis="{ax} 0 0" range="-0.1 0.9"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.05" size="0.005"/>
        <body name="{s}_coupler" pos="0 0 -0.05">
          <joint name="{s}_coupler_pivot" class="pivot"/>
          <geom type="capsule" fromto="0 0 0 0 {w} 0" size="0.004"/>
          <geom name="{s}_pad" type="box" pos="0 {pad} -0.03" size="0.01 0.003 0.03"/>
        </body>
      </body>
      <body name="{s}_follower" pos="0 {y2} -0.02">
        <joint name="{s}_follower_pivot" class="pivot"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.05" size="0.003"/>
      </body>"""


def gripper_xml():
    fingers = ""
    for s, sign in (("left", 1.0), ("right", -1.0)):
        fingers += FINGER.format(s=s, y=0.015 * sign, y2=0.035 * sign, ax=-sign, w=0.02 * sign, pad=-0.004 * sign)
    return GRIPPER.format(arm=PIVOT_ARMATURE, ref=PIVOT_REF, fingers=fingers)


def _hinge_frame(spec, body):
    """``(pos, quat)`` in the parent's frame of an element frame whose z axis is the body's (only) hinge's axis, turned
    there from the body's z by the shortest rotation (for the gripper's pivots, along the body's x, the element's x
    is then the body's -z: along the finger link, the notch's beam axis)."""
    model = spec.compile()
    b = model.body(body).id
    j = model.body_jntadr[b]
    axis = model.jnt_axis[j]  # body frame
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, axis), float(z @ axis)
    q = np.array([1.0 + c, *v]) if c > -1 + 1e-12 else np.array([0.0, 1.0, 0.0, 0.0])
    q /= np.linalg.norm(q)
    R_PB = np.empty(9)
    mujoco.mju_quat2Mat(R_PB, model.body_quat[b])
    R_PB = R_PB.reshape(3, 3)
    p = model.body_pos[b] + R_PB @ model.jnt_pos[j]
    q_P = np.empty(4)
    mujoco.mju_mulQuat(q_P, model.body_quat[b], q)
    return p, q_P


def gripper(xml=None):
    """``(rigid, full, info)``: the four-bar gripper (or ``xml``, a variant of it), and with its four passive pivots
    as steel notch hinges."""
    rigid = mujoco.MjSpec.from_string(xml or gripper_xml())
    full = mujoco.MjSpec.from_string(xml or gripper_xml())
    K = notch_hinge_stiffness(**NOTCH)
    for s in ("left", "right"):
        for part in ("follower", "coupler"):
            body = f"{s}_{part}"
            pos, quat = _hinge_frame(full, body)
            mjflex.make_compliant(full, body, K, pos=pos, quat=quat, frame="parent", replace_joints=True,
                                  name=f"{body}_notch", damping_ratio=0.02)  # fmt: skip
    return rigid, full, {"ctrl": lambda t: [0.6 if t > 1.0 else 0.0, 0.1 if t > 3.0 else 0.0], "keyframe": "open"}


SPINE_MUSCLES = """<tendon>
    <fixed name="erector">
      <joint joint="L4_flex" coef="1"/><joint joint="L3_flex" coef="1"/><joint joint="L2_flex" coef="1"/>
    </fixed>
    <fixed name="oblique">
      <joint joint="L4_bend" coef="1"/><joint joint="L3_bend" coef="1"/><joint joint="L2_bend" coef="1"/>
    </fixed>
  </tendon>
  <actuator>
    <muscle name="erector_m" tendon="erector" lengthrange="-0.6 0.6" force="60"/>
    <muscle name="oblique_m" tendon="oblique" lengthrange="-0.6 0.6" force="40"/>
  </actuator>"""


#: The facets' armature [kg m^2] (the muscles' and the surrounding tissue's inertia on each hinge).
FACET_ARMATURE = 1e-3


def spine_scene_xml():
    xml = spine_xml(torso_mass=2.0)
    xml = xml.replace('timestep="5e-4" integrator="RK4"', 'timestep="0.002" integrator="implicitfast"')
    xml = xml.replace('density="1500"', 'mass="0.1"').replace('armature="1e-4"', f'armature="{FACET_ARMATURE}"')
    xml = xml.replace('ctrl="0.1 0.02 0"/>', 'ctrl="0.1 0.02 0 0.2 0.1"/>')
    return xml.replace("</mujoco>", SPINE_MUSCLES + "\n</mujoco>")


#: The disc's stiffness: bending 1.5, flexion 1.2 and axial rotation 4 N m/deg; shear 150 and compression 1500 N/mm.
U = mjflex.units
K_DISC = [1.5 * U.N_m_per_deg, 1.2 * U.N_m_per_deg, 4 * U.N_m_per_deg, 150 * U.N_per_mm, 150 * U.N_per_mm,
          1500 * U.N_per_mm]  # fmt: skip


def spine():
    """``(rigid, full, info)``: the spine with muscles at 2 ms, and with L3's hinges replaced by a disc."""
    rigid = mujoco.MjSpec.from_string(spine_scene_xml())
    full = mujoco.MjSpec.from_string(spine_scene_xml())
    mjflex.make_compliant(full, "L3", K_DISC, replace_joints=True, name="disc", damping_ratio=0.05)
    return rigid, full, {"ctrl": lambda t: [0.3 * math.sin(3 * t), 0.1, 0.0, 0.5 + 0.4 * math.sin(2 * t), 0.3],
                         "keyframe": "bent"}  # fmt: skip


#: The compliant wrist: soft about its flexion axis (element z), stiff in the other five directions.
K_WRIST = [2000.0, 2000.0, 6.0, 1e6, 1e6, 1e6]
#: The pusher's keyframe "push": torques on its seven motors [N m] (the file has no gravity).
PUSH = [0.0, 0.0, 0.0, 0.0, 0.0, -0.3, 0.0]


def pusher_wrist():
    """``(rigid, full, info)``: gymnasium's pusher, and with ``r_wrist_flex_joint`` a compliant wrist."""
    rigid = mujoco.MjSpec.from_file(pusher_path())
    full = mujoco.MjSpec.from_file(pusher_path())
    for spec in (rigid, full):  # the scene's load: the motors holding a pose against the arm's springs-free joints
        spec.add_key(name="push", qpos=spec.compile().qpos0, ctrl=PUSH)
    # its range as element stops: the scene that tests them through a reduction (the module docstring)
    mjflex.make_compliant(
        full, "r_wrist_flex_link", K_WRIST, replace_joints=True, name="wrist", damping_ratio=0.05, stops="element"
    )
    return rigid, full, {"ctrl": lambda t: [0.5 * math.sin(t + k) for k in range(7)], "keyframe": "push"}


SCENES = {"gripper": gripper, "spine": spine, "pusher_wrist": pusher_wrist}
