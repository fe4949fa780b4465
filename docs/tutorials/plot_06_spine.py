"""
A spine: vertebrae on hinges, one level replaced by a disc with stops
=====================================================================

Musculoskeletal models join vertebrae by three hinges per level (flexion, lateral bending, axial rotation) and tie
the levels together with equality constraints; ranges limit each hinge. Here such a model is built from scratch,
one level is replaced by an intervertebral disc (a full 6×6 element with literature stiffness) in one call, and the
disc's statics, modes, time step and a loaded run are checked: the hinges' ranges become the disc's end stops
(``stops="element"``; by default they would stay MuJoCo's joint limits), and the run stays within them.

Run it as a script: ``python docs/tutorials/plot_06_spine.py``.
"""

# %%
# The spine
# ---------
# A fixed sacrum, four lumbar vertebrae L5 to L2 stacked 35 mm apart, and a 2 kg torso welded on L2. Each vertebra
# hangs on its lower neighbour by three hinges at its base: flexion about y, lateral bending about x, axial
# rotation about z, with ranges in degrees, a spring and a damper. L5 drives: joint equalities make L4, L3 and L2
# follow its angles with fixed shares, as public lumbar models do.
import matplotlib.pyplot as plt
import mujoco
import numpy as np

import mjflex

HINGES = {"flex": ("0 1 0", "-10.7 4.8"), "bend": ("1 0 0", "-6 6"), "rot": ("0 0 1", "-3 3")}
SHARE = {"L4": (0.9, 1.0, 0.8), "L3": (0.8, 0.9, 0.6), "L2": (0.7, 0.8, 0.5)}  # of L5's flex, bend, rot

bodies = ""
for level in ("L5", "L4", "L3", "L2"):
    joints = "".join(
        f'<joint name="{level}_{h}" class="facet" axis="{a}" range="{r}"/>' for h, (a, r) in HINGES.items()
    )
    bodies += f'<body name="{level}" pos="0 0 0.035">{joints}<geom/>'
bodies += '<body name="torso" pos="0 0 0.15"><geom type="box" size="0.1 0.06 0.12" mass="2"/></body>' + "</body>" * 4
equalities = "".join(
    f'<joint name="{level}_{h}_follows" joint1="{level}_{h}" joint2="L5_{h}" polycoef="0 {c} 0 0 0"/>'
    for level, shares in SHARE.items()
    for h, c in zip(HINGES, shares, strict=True)
)
SPINE = f"""<mujoco model="spine">
  <option timestep="2e-4" integrator="RK4"/>
  <default>
    <default class="facet"><joint stiffness="20" damping="0.2" armature="1e-4" limited="true"/></default>
    <geom type="cylinder" size="0.02 0.012" density="1500"/>
  </default>
  <worldbody><body name="sacrum" pos="0 0 0.5"><geom/>{bodies}</body></worldbody>
  <equality>{equalities}</equality>
</mujoco>"""
spec = mujoco.MjSpec.from_string(SPINE)
original = spec.compile()
print(f"{original.nv} hinges, {original.neq} equalities")

# %%
# One level becomes a disc
# ------------------------
# The disc between L4 and L3 gets stiffness from the literature, given in N m/deg and N/mm (:mod:`mjflex.units`
# converts them): bending 1.5, flexion 1.2 and axial rotation 4 N m/deg; shear 150 and compression 1500 N/mm.
# ``replace_joints=True`` hands L3's three hinges to the element: they stay as its coordinates (so everything that
# names them keeps its meaning) without their springs and dampers (their armature stays); L3 gets three slides for
# the translations; the three equalities that drove L3 go (the disc determines its motion now). ``stops="element"``
# makes the hinges' ranges the disc's stops (by default they stay MuJoCo's joint limits on the hinges:
# :doc:`/howto/add_flexures_to_a_robot` says when to prefer which). Its damping is 5 % in each of its modes, computed
# with the other levels free and the equalities as rigid couplings (``constraints="project"``).
u = mjflex.units
K_disc = [1.5 * u.N_m_per_deg, 1.2 * u.N_m_per_deg, 4 * u.N_m_per_deg, 150 * u.N_per_mm, 150 * u.N_per_mm,
          1500 * u.N_per_mm]  # fmt: skip
disc = mjflex.make_compliant(spec, "L3", K_disc, replace_joints=True, name="disc", damping_ratio=0.05, others="free",
                             constraints="project", stops="element")  # fmt: skip
print(disc)
for edit in disc.replaced.edits:
    print(f"  {edit.kind} {edit.name}: {edit.action} ({edit.detail})")
lower, upper = np.degrees(disc.replaced.lower[:3]), np.degrees(disc.replaced.upper[:3])
print("  stops [deg] on rx, ry, rz:", lower.round(2), "to", upper.round(2))
model = spec.compile()
flex = mjflex.Flexures(model)

# %%
# Statics
# -------
# A forward push on the torso, 15 N, extends the spine. :func:`mjflex.static_equilibrium` finds the rest pose under
# it and gravity (Newton's method on MuJoCo's own forces, the equalities included). The disc carries the wrench that
# the element exerts there; :func:`mjflex.static_deflection` of that wrench, applied at the disc's frame, gives its
# deflection alone, exactly: the same as in the whole model while no stop is engaged.
torso = model.body("torso").id
push = np.zeros((model.nbody, 6))
push[torso, 0] = 15.0
rest = mjflex.static_equilibrium(model, flex, xfrc_applied=push)
data = mujoco.MjData(model)
data.qpos[:] = rest
mujoco.mj_kinematics(model, data)
displacement = flex.displacements(data)[0]
R_Wb = data.site_xmat[flex.site_ids[0, 1]].reshape(3, 3)
W = -flex.wrenches(data)[0]  # the load on L3 at the disc's frame b, world axes
R_ab = data.site_xmat[flex.site_ids[0, 0]].reshape(3, 3).T @ R_Wb
alone = mjflex.static_deflection(flex.records[0].K, np.concatenate([R_ab @ R_Wb.T @ W[:3], R_ab @ R_Wb.T @ W[3:]]))
print(f"disc extension under 15 N: {np.degrees(displacement[1]):.3f} deg (its stop at {upper[1]:.1f})")
print(f"static_deflection of its wrench: {np.degrees(alone.twist[1]):.3f} deg, "
      f"largest difference {np.abs(alone.twist - displacement).max():.1e}")  # fmt: skip

# %%
# Modes and the time step where the spine runs
# --------------------------------------------
# A 40 N push extends the disc past its 4.8 deg stop. :func:`mjflex.step_advice` takes MuJoCo's own step at that
# pose and at the rest under gravity alone (not at ``qpos0``, where gravity is not balanced: the advice would say
# so): the engaged stop (100 times the disc's stiffness), the load, the springs and dampers, and the equalities as
# MuJoCo's solver applies them, soft by their default ``solref``; so does :func:`mjflex.normal_modes` with
# ``constraints="spring"``. Runs from the pushed pose confirm the advised limit, and equalities projected as rigid
# loop closures would add a stiff mode this model does not have (``scripts/operating_pose.py``:
# :doc:`/howto/add_flexures_to_a_robot`, "Advice at the operating pose").
push[torso, 0] = 40.0
loaded = mjflex.static_equilibrium(model, flex, xfrc_applied=push)
settled = mjflex.static_equilibrium(model, flex)
where = {"at rest": {"qpos": settled}, "pushed by 40 N": {"qpos": loaded, "xfrc_applied": push}}
for label, state in where.items():
    freq, _ = mjflex.normal_modes(model, flex, constraints="spring", joint_springs=True, gravity=True, **state)
    print(f"{label}: top frequencies {np.round(freq[-3:], 0)} Hz; {mjflex.step_advice(model, flex, **state)}")
advice = mjflex.step_advice(model, flex, qpos=loaded, xfrc_applied=push)

# %%
# A loaded run, with and without the stops
# ----------------------------------------
# The push comes at once, from rest; each run takes the step advised at the loaded pose. With the stops the disc
# stays at its range (past it by the stop's own compliance); without them (``stops=False``), it swings past 10 deg.
# A run that does not diverge is the check of the advised step.
runs = {}
for stops in ("element", False):
    s = mujoco.MjSpec.from_string(SPINE)
    mjflex.make_compliant(s, "L3", K_disc, replace_joints=True, name="disc", damping_ratio=0.05, others="free",
                          constraints="project", stops=stops)  # fmt: skip
    m = s.compile()
    f = mjflex.Flexures(m)
    m.opt.timestep = advice.recommended
    d = mujoco.MjData(m)
    d.xfrc_applied[:] = push
    t, ry = [], []
    while d.time < 1.0:
        mujoco.mj_step(m, d)
        t.append(d.time)
        ry.append(f.displacements(d)[0][1])
    runs["with stops" if stops else "without stops"] = np.array(t), np.degrees(ry)
for label, (_, ry) in runs.items():
    print(f"{label}: peak extension {ry.max():.2f} deg, at 1 s {ry[-1]:.2f} deg (range ends at {upper[1]:.1f} deg)")

fig, ax = plt.subplots(figsize=(6.4, 3.2))
for label, (t, ry) in runs.items():
    ax.plot(t, ry, label=label)
ax.axhline(upper[1], color="k", lw=0.8, ls="--", label="range of the hinges")
ax.set(xlabel="time [s]", ylabel="disc extension about y [deg]", title="40 N push on the torso, from rest")
ax.legend()
fig.tight_layout()

# %%
# Back to the hinges
# ------------------
# :func:`mjflex.make_rigid` puts it all back: the hinges' ranges, springs and dampers, the three equalities in their
# places, the keyframes. The compiled model is the original one. (The spec still declares the plugin, which MjSpec
# cannot take back: save it with :func:`mjflex.spec_xml`, which leaves the declaration out.)
mjflex.make_rigid(spec, disc)
again = spec.compile()
same = all(np.array_equal(getattr(again, n), getattr(original, n)) for n in ("jnt_range", "eq_data", "eq_obj1id",
                                                                             "dof_damping", "qpos0"))  # fmt: skip
print(f"restored: nv {again.nv}, {again.neq} equalities, arrays equal: {same}")
