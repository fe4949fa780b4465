"""
Your first flexure: a pendulum on a notch hinge
===============================================

From nothing to a running model: a 50 g pendulum hangs from an aluminium notch hinge. We compute the hinge's
stiffness from its geometry, write the model once as an MJCF file and once from Python, simulate a swing and
compare it with the frequency of the linearized pendulum.

**Set-up** (once, from a clone of the repository)::

    python3 -m venv .venv && . .venv/bin/activate && python -m pip install -e .

Then run this page as a script: ``python docs/tutorials/plot_01_first_flexure.py``.
"""

# %%
# Stiffness from geometry
# -----------------------
# A right-circular notch hinge: two circular cuts of radius ``R`` leave a web of thickness ``t``, over a width
# ``b``. :func:`mjflex.geometry.notch_hinge_stiffness` returns its 6×6 stiffness at the hinge's centre, rows
# ``[rot_x, rot_y, rot_z, x, y, z]`` with ``x`` along the flexure and ``z`` the axis it bends about (N m/rad and
# N/m), from stored finite-element tables whose error bands are stored with them
# (:doc:`/background/stiffness_from_geometry`).
import matplotlib.pyplot as plt
import mujoco
import numpy as np

import mjflex
from mjflex.geometry.tables import error_bands

R, t, b = 2e-3, 0.3e-3, 5e-3  # cut radius, web thickness, width [m]
E, nu = 70e9, 0.33  # aluminium [Pa]
K = mjflex.geometry.notch_hinge_stiffness(R, t, b, E, nu)
k_bend = K[2, 2]
print(f"compliant rotation {k_bend:.3f} N m/rad; torsion {K[0, 0]:.3g} N m/rad; axial {K[3, 3]:.3g} N/m")
band = error_bands("notch")["rot_z"]["total"]
print(f"the tables' error in the compliant rotation: at most {band:.2%} over their range")

# %%
# Damping: 1 % of critical in the swing. Only the compliant rotation is damped here; ``B`` has the layout of ``K``.
inertia = 0.05 * 0.1**2  # tip mass times arm squared [kg m^2]: a first estimate, refined below
B = np.zeros(6)
B[2] = 2 * 0.01 * np.sqrt(k_bend * inertia)

# %%
# The model file
# --------------
# The pendulum is a free body whose frame sits at the hinge; the hinge joins it to the world. An element named
# ``hinge`` is two sites, ``hinge/a`` on the world and ``hinge/b`` on the pendulum, at the same pose: the element
# frame. Its ``x`` axis points down the pendulum and its ``z`` axis, the compliant one, along the world's ``y``
# (``xyaxes`` gives the frame's x and y axes).
#
# The element's parameters are the configuration of an instance of mjflex's engine plugin ``mjflex.flexure``:
# ``import mujoco`` loads the plugin (mjflex registers it when installed), so this file runs in any MuJoCo program,
# MuJoCo's own viewer included, and its forces belong to the model: there is nothing to install. ``K`` and ``B``
# are given by their diagonals here (6 numbers; 36 for a full matrix).
#
# .. note:: **The element's format.** This block is the one place of the tutorial that writes an element by hand:
#    the two sites, and the stiffness and damping as the plugin instance ``hinge``. The same element can be a text
#    record ``mjflex:hinge`` instead, served by the ``mjcb_passive`` provider (``python -m mjflex convert`` turns
#    one into the other); both formats, every key and the rules they are checked by: :doc:`/reference/mjcf_schema`,
#    and when to use which: :doc:`/howto/plugin_models`. Everything below works the same on either.
numbers = " ".join  # a config value is text: numbers separated by spaces, every digit kept by repr
xml = f"""
<mujoco model="pendulum">
  <option timestep="1e-5" integrator="RK4" gravity="0 0 -9.81"/>
  <worldbody>
    <site name="hinge/a" pos="0 0 0" xyaxes="0 0 -1 -1 0 0"/>
    <body name="pendulum" pos="0 0 0">
      <freejoint/>
      <geom type="capsule" fromto="0 0 -0.005 0 0 -0.09" size="0.003" density="2700"/>
      <geom type="sphere" pos="0 0 -0.1" size="0.01" mass="0.05"/>
      <site name="hinge/b" pos="0 0 0" xyaxes="0 0 -1 -1 0 0"/>
    </body>
  </worldbody>
  <extension>
    <plugin plugin="mjflex.flexure">
      <instance name="hinge">
        <config key="site_a" value="hinge/a"/>
        <config key="site_b" value="hinge/b"/>
        <config key="K" value="{numbers(repr(float(k)) for k in np.diag(K))}"/>
        <config key="B" value="{numbers(repr(float(c)) for c in B)}"/>
      </instance>
    </plugin>
  </extension>
</mujoco>
"""
model = mujoco.MjModel.from_xml_string(xml)
flex = mjflex.Flexures(model)  # reads and checks every element once
print(flex)

# %%
# The time step
# -------------
# The flexure's forces enter MuJoCo's integrators explicitly, so the step must resolve the model's fastest mode:
# undamped, RK4 is stable below ``2√2 / omega_max``. The hinge is soft in one rotation and very stiff in the others
# and in translation; the normal modes of the linearized model show how stiff.
freq, _ = mjflex.normal_modes(model, flex)
omega_max = 2 * np.pi * freq[-1]
print(f"highest mode {freq[-1]:.0f} Hz: RK4 stable below {2 * np.sqrt(2) / omega_max:.2g} s; the model uses 1e-5 s")

# %%
# :func:`mjflex.normal_modes` linearizes at ``qpos0`` (or a keyframe); the same rule with a margin, and the
# integrators' other limits, are in :doc:`/howto/choose_method_integrator_step`.

# %%
# Simulate
# --------
# Start the pendulum 0.1 rad out of the vertical, at rest, and step it for half a second: MuJoCo's ``mj_step`` calls
# the plugin, which adds the element's forces. The element's displacement, a finite twist read by ``flex``, gives the
# hinge rotation: component 2 is the rotation about the compliant axis. (``with flex:`` installs the passive-force
# callback a text-record element needs; for a plugin element it does nothing, so the function serves both forms.)


def swing(model, flex, duration=0.5, angle=0.1, every=50):
    data = mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(angle / 2), 0, np.sin(angle / 2), 0]  # rotated about world y
    times, angles = [], []
    with flex:
        for step in range(round(duration / model.opt.timestep)):
            if step % every == 0:
                mujoco.mj_forward(model, data)
                times.append(data.time)
                angles.append(flex.displacements(data)[0, 2])
            mujoco.mj_step(model, data)
    return np.array(times), np.array(angles)


time, angle = swing(model, flex)

# %%
# Against the linearized pendulum
# -------------------------------
# For small swings the pendulum is a damped oscillator: stiffness ``k + m g l`` (the hinge plus gravity) over the
# inertia about the hinge axis. MuJoCo's mass matrix at the hinge gives that inertia: the pendulum's free joint
# measures rotations about the body frame, whose origin is the hinge.
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
M = np.zeros((model.nv, model.nv))
mujoco.mj_fullM(model, data, M)
inertia = M[4, 4]  # rotation about y
mass, arm = model.body_mass[1], -model.body_ipos[1, 2]
omega = np.sqrt((k_bend + mass * 9.81 * arm) / inertia)
zeta = B[2] / (2 * np.sqrt((k_bend + mass * 9.81 * arm) * inertia))
omega_d = omega * np.sqrt(1 - zeta**2)
linear = 0.1 * np.exp(-zeta * omega * time) * (np.cos(omega_d * time) + zeta * omega / omega_d * np.sin(omega_d * time))

crossings = time[1:][np.diff(np.sign(angle)) != 0]
measured = 1 / (2 * np.mean(np.diff(crossings)))
print(f"linearized {omega_d / (2 * np.pi):.3f} Hz, simulated {measured:.3f} Hz (zero crossings)")
print(f"largest difference from the linearized swing: {np.max(np.abs(angle - linear)) / 0.1:.2%} of the amplitude")

fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
ax.plot(time, np.degrees(angle), label="mjflex (RK4, 10 µs)")
ax.plot(time, np.degrees(linear), "--", label=f"linearized, {omega_d / (2 * np.pi):.2f} Hz")
ax.set(xlabel="time [s]", ylabel="hinge rotation [deg]", title="Pendulum on a notch hinge")
ax.legend(loc="upper right")

# %%
# The swing follows the linearized pendulum closely; what is left is the amplitude-dependence of a real pendulum
# (gravity's ``sin``) and of the finite-twist hinge. The rotation is the element's own, measured between its two
# frames: with the world as body A it is the pendulum's angle about the element's ``z`` axis (world ``y``).

# %%
# The same model from Python
# --------------------------
# :func:`mjflex.add_flexure` writes both sites, the plugin instance and (between two bodies) the contact exclusion
# into a :class:`mujoco.MjSpec`; the element frame's pose is given in world coordinates, as a w-first quaternion.
# The rotation here maps the frame's axes as ``xyaxes`` did above.
spec = mujoco.MjSpec()
spec.option.timestep = 1e-5
spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
body = spec.worldbody.add_body(name="pendulum")
body.add_freejoint()
body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, -0.005, 0, 0, -0.09], size=[0.003, 0, 0], density=2700)
body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0, 0, -0.1], size=[0.01, 0, 0], mass=0.05)
R_WE = np.array([[0, -1, 0], [0, 0, 1], [-1, 0, 0]], dtype=float)  # columns: the element's x, y, z in world
quat = np.zeros(4)
mujoco.mju_mat2Quat(quat, R_WE.ravel())
mjflex.add_flexure(spec, "hinge", "world", "pendulum", pos=[0, 0, 0], quat=quat, K=K, B=B)
model_py = spec.compile()
time_py, angle_py = swing(model_py, mjflex.Flexures(model_py))
print(f"largest difference between the two models: {np.max(np.abs(angle_py - angle)):.2e} rad")

# %%
# ``spec.to_xml()`` writes this model as a file like the one above, with every digit of ``K`` kept.
#
# Damping from a ratio
# --------------------
# The damping above came from a hand estimate of the pendulum's inertia. :func:`mjflex.damping_from_ratios` takes
# the inertia from the model instead: the element's modes from a modal analysis (here with gravity's stiffness,
# which a pendulum's swing has), each given the ratio asked for.
B_ratio = mjflex.damping_from_ratios(model_py, "hinge", 0.01, gravity=True)  # gravity stiffens the swing
print(f"B about the hinge axis: hand estimate {B[2]:.3g}, from the model {B_ratio[2, 2]:.3g} N m s/rad")

# %%
# The hand estimate ignored gravity's stiffness and the rod's inertia; the ratio from the model is what a log
# decrement of the free swing measures.
#
# Your own flexure model
# ----------------------
# The steps of this page, for a part of your own:
#
# 1. **Stiffness**: :func:`mjflex.geometry.notch_hinge_stiffness` or :func:`mjflex.geometry.leaf_spring_stiffness`
#    for those shapes (with their error bands, :doc:`/background/stiffness_from_geometry`); otherwise a measured or
#    computed 6×6 ``K``, moved to the element frame with :func:`mjflex.stiffness_in_frame` (or ``stiffness_frame=``
#    of :func:`mjflex.add_flexure`) if it was given at another point.
# 2. **Frame**: where the part is, its ``z`` axis along the compliant rotation; a site of one of the two bodies is
#    the easiest way to state it (``add_flexure(..., site=...)``).
# 3. **Element**: :func:`mjflex.add_flexure` on an ``MjSpec``, or by hand in the file (:doc:`/reference/mjcf_schema`);
#    in a robot whose body is welded to its parent, :func:`mjflex.make_compliant` does it all
#    (:doc:`/howto/add_flexures_to_a_robot`). Bodies joined by an element must not collide: ``add_flexure`` excludes
#    the pair.
# 4. **Damping**: :func:`mjflex.damping_from_ratios`, or ``B`` measured.
# 5. **Time step**: from :func:`mjflex.normal_modes`, below ``2√2 / omega_max`` for RK4 (the limits:
#    :ref:`step-limits`); for the accuracy you need, ``mjflex study`` on your scene
#    (:doc:`plot_03_speed_against_accuracy`).
#
# Next: :doc:`plot_02_arcade_guide` (a mechanism of 48 flexures), or the reference for :class:`mjflex.Flexures`
# (energies, wrenches, switches) and :func:`mjflex.add_flexure`.
