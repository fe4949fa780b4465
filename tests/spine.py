"""A hand-built lumbar spine for the tests of replaced joints (mjflex.make_compliant(..., replace_joints=True)).

Four vertebrae L5 (on the fixed sacrum) to L2, and a torso welded on L2. Each vertebra hangs on its lower
neighbour by three hinges at its base: flexion about y, lateral bending about x, axial rotation about z, with
ranges in degrees (the compiler converts them), springs, dampers and armature from a default class. Joint
equalities tie L4, L3 and L2 to L5 level by level (L5 drives), as public musculoskeletal models do. A motor and a
position servo (its control range inherited from the joint's range) act on L3, sensors read L3 and L4 (one of them
L3's limit) and the tendon, a fixed tendon sums the flexion of L4 and L5, and a keyframe
bends the spine (consistent with the equalities) and sets it moving.
"""

import math

import mujoco
import numpy as np

import mjflex

LEVELS = ("L5", "L4", "L3", "L2")
#: (name suffix, axis, range [deg]).
HINGES = (("flex", "0 1 0", (-10.7, 4.8)), ("bend", "1 0 0", (-6.0, 6.0)), ("rot", "0 0 1", (-3.0, 3.0)))
#: How much of L5's motion each level follows, per hinge: joint1 = c * joint2 (MuJoCo's polycoef a1).
FOLLOW = {"L4": (0.9, 1.0, 0.8), "L3": (0.8, 0.9, 0.6), "L2": (0.7, 0.8, 0.5)}
#: The keyframe's L5 angles [rad] (flex, bend, rot) and rates [rad/s]; the other levels follow.
KEY_ANGLES, KEY_RATES = (-0.08, 0.05, 0.02), (0.3, -0.2, 0.1)
HEIGHT = 0.035  # m between vertebrae


def spine_xml(*, tendon=True, quadratic=False, torso_mass=2.0, joint_damping=0.2, stiffness=20.0,
              solref=None) -> str:  # fmt: skip
    """The model's MJCF. ``tendon``: the fixed tendon over L4 and L5's flexion; ``quadratic``: L2's rotation
    follows L5's with a quadratic term too; ``solref``: the equalities' time constant and damping ratio, with an
    impedance of 0.9999 (MuJoCo's default, 20 ms and 0.9-0.95, is soft at the disc's frequencies)."""
    bodies = ""
    for level in LEVELS:
        joints = "".join(
            f'<joint name="{level}_{h}" class="facet" axis="{axis}" range="{lo} {hi}"/>' for h, axis, (lo, hi) in HINGES
        )
        bodies += (
            f'<body name="{level}" pos="0 0 {HEIGHT}">{joints}<geom name="{level}_body"/>'
            f'<site name="{level}_top" pos="0 0 0.012"/>'
        )
    torso = f'<body name="torso" pos="0 0 0.15"><geom type="box" size="0.1 0.06 0.12" mass="{torso_mass}"/></body>'
    bodies += torso + "</body>" * len(LEVELS)
    equalities = ""
    for level, coefs in FOLLOW.items():
        for (h, _, _), c in zip(HINGES, coefs, strict=True):
            quad = 0.1 if quadratic and level == "L2" and h == "rot" else 0.0
            equalities += (
                f'<joint name="{level}_{h}_follows" joint1="{level}_{h}" joint2="L5_{h}" polycoef="0 {c} {quad} 0 0"'
                + (f' solref="{solref[0]} {solref[1]}" solimp="0.9999 0.9999 0.001"/>' if solref else "/>")
            )
    fixed = (
        '<tendon><fixed name="flex45"><joint joint="L4_flex" coef="1"/><joint joint="L5_flex" coef="1"/></fixed>'
        "</tendon>"
        if tendon
        else ""
    )
    tendon_sensor = '<tendonpos name="flex45_length" tendon="flex45"/>' if tendon else ""
    return f"""<mujoco model="spine">
  <compiler angle="degree"/>
  <option timestep="5e-4" integrator="RK4"/>
  <default>
    <default class="facet">
      <joint type="hinge" pos="0 0 0" stiffness="{stiffness}" damping="{joint_damping}" armature="1e-4"
             limited="true"/>
    </default>
    <geom type="cylinder" size="0.02 0.012" density="1500"/>
  </default>
  <worldbody>
    <body name="sacrum" pos="0 0 0.5"><geom name="sacrum_body"/>{bodies}</body>
  </worldbody>
  <equality>{equalities}</equality>
  {fixed}
  <actuator>
    <motor name="L3_flexor" joint="L3_flex" gear="2"/>
    <position name="L3_bender" joint="L3_bend" kp="50" inheritrange="1"/>
    <motor name="L4_flexor" joint="L4_flex"/>
  </actuator>
  <sensor>
    <jointpos name="L3_flex_angle" joint="L3_flex"/>
    <framequat name="L5_orientation" objtype="site" objname="L5_top"/>
    <jointvel name="L3_rot_rate" joint="L3_rot"/>
    <jointpos name="L4_flex_angle" joint="L4_flex"/>
    <jointlimitpos name="L3_flex_limit" joint="L3_flex"/>{tendon_sensor}
  </sensor>
  <keyframe>{key_xml()}</keyframe>
</mujoco>"""


def key_values():
    """``(qpos, qvel)`` of the keyframe: L5's angles and rates, the other levels following by the equalities."""
    qpos, qvel = [], []
    for level in LEVELS:
        c = (1.0, 1.0, 1.0) if level == "L5" else FOLLOW[level]
        qpos += [ci * a for ci, a in zip(c, KEY_ANGLES, strict=True)]
        qvel += [ci * a for ci, a in zip(c, KEY_RATES, strict=True)]
    return np.array(qpos), np.array(qvel)


def key_xml():
    qpos, qvel = key_values()
    return (f'<key name="bent" qpos="{" ".join(map(repr, qpos.tolist()))}" '
            f'qvel="{" ".join(map(repr, qvel.tolist()))}" ctrl="0.1 0.02 0"/>')  # fmt: skip


def spine_spec(**kwargs) -> mujoco.MjSpec:
    return mujoco.MjSpec.from_string(spine_xml(**kwargs))


def radians(lo_hi):
    return tuple(math.radians(v) for v in lo_hi)


#: The disc of :func:`spine_on_its_stop` (N m/rad, N/m) and the push [N] forward on the torso that extends it past
#: its 4.8 deg flexion stop.
K_SPINE_DISC, STOP_PUSH = (30.0, 30.0, 20.0, 2e5, 2e5, 5e5), 40.0


def spine_on_its_stop(integrator, stops=None):
    """``(model, flex, qpos, xfrc_applied)``: the spine (MuJoCo's default, soft ``solref`` on its equalities) with L3
    replaced by a disc (``K_SPINE_DISC``, 5 % damping, the hinges' ranges as its stops), ``integrator`` (MuJoCo's
    name), pushed by ``STOP_PUSH`` on the torso: its static equilibrium there, the flexion stop engaged."""
    spec = spine_spec()
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    mjflex.make_compliant(spec, "L3", list(K_SPINE_DISC), replace_joints=True, damping_ratio=0.05, stops=stops)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    xfrc = np.zeros((model.nbody, 6))
    xfrc[model.body("torso").id, 0] = STOP_PUSH
    return model, flex, mjflex.static_equilibrium(model, flex, xfrc_applied=xfrc), xfrc
