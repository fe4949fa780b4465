"""Small MuJoCo models built with MjSpec for the tests of the MuJoCo layer."""

import contextlib

import mujoco
import numpy as np

import mjflex

# Two bodies, explicit principal inertias so that the body frame is the inertial frame.
MASS = (1.3, 0.8)
INERTIA = ((0.010, 0.014, 0.018), (0.006, 0.011, 0.007))
K_DEMO = np.array(
    [
        [0.50, 0.02, -0.01, 0.05, 0.00, 0.02],
        [0.02, 0.70, 0.03, 0.00, -0.04, 0.01],
        [-0.01, 0.03, 0.60, 0.01, 0.02, 0.00],
        [0.05, 0.00, 0.01, 80.0, 5.0, -3.0],
        [0.00, -0.04, 0.02, 5.0, 120.0, 4.0],
        [0.02, 0.01, 0.00, -3.0, 4.0, 100.0],
    ]
)
B_DEMO = 0.02 * K_DEMO


def two_body_spec(*, method="twist", K=K_DEMO, B=None, integrator="RK4", timestep=1e-3, gravity=False, terms=None,
                  kind="record"):  # fmt: skip
    """Bodies A and B on free joints joined at their midpoint by one flexure ``link`` (``kind``: how it is written)."""
    spec = mujoco.MjSpec()
    spec.modelname = "two_body"
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.timestep = timestep
    if not gravity:
        spec.option.gravity = [0, 0, 0]
    for name, pos, quat, mass, inertia in (
        ("A", [0.0, 0.0, 0.5], [1, 0, 0, 0], MASS[0], INERTIA[0]),
        ("B", [0.2, 0.05, 0.5], [0.9, 0.1, -0.3, 0.2], MASS[1], INERTIA[1]),
    ):
        body = spec.worldbody.add_body(name=name, pos=pos, quat=quat, mass=mass, inertia=inertia,
                                       ipos=[0, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
        body.explicitinertial = True
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.03, 0, 0], contype=0, conaffinity=0, mass=0, density=0)
    mjflex.add_flexure(spec, "link", "A", "B", pos=[0.1, 0.02, 0.5], quat=[0.8, 0.0, 0.6, 0.0], K=K, B=B, method=method,
                       terms=terms, kind=kind)  # fmt: skip
    return spec


def push_after_rest(model, rest=40, steps=300, provider=True):
    """qvel history after ``rest`` steps at rest (long enough to fall asleep) and a push of body A (two_body_spec).

    ``provider``: install a :class:`mjflex.Flexures` (text records need it; it also keeps joined trees awake in the
    compiled model); False: the model alone, as in a program without mjflex (plugin elements).
    """
    data = mujoco.MjData(model)
    out = []
    with mjflex.Flexures(model) if provider else contextlib.nullcontext():
        for _ in range(rest):
            mujoco.mj_step(model, data)
        data.qvel[0:3] = [0.3, 0.0, 0.0]
        for _ in range(steps):
            mujoco.mj_step(model, data)
            out.append(data.qvel.copy())
    return np.array(out)


def hinge_chain_spec(*, n=3, K=K_DEMO, B=None, method="twist", integrator="RK4", timestep=1e-3, terms=None,
                     kind="record"):  # fmt: skip
    """A chain hanging from the world: hinge, slide+hinge, ball joints; flexures between neighbours."""
    spec = mujoco.MjSpec()
    spec.modelname = "chain"
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.timestep = timestep
    spec.option.gravity = [0, 0, 0]
    parent = spec.worldbody
    for i in range(n):
        body = parent.add_body(name=f"link{i}", pos=[0.0, 0.0, -0.1] if i else [0.0, 0.0, 1.0])
        if i % 3 == 0:
            body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], pos=[0, 0, 0.05])
        elif i % 3 == 1:
            body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
            body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 1], pos=[0.01, 0, 0])
        else:
            body.add_joint(type=mujoco.mjtJoint.mjJNT_BALL)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0.02, 0, -0.08], size=[0.01, 0, 0],
                      density=2000, contype=0, conaffinity=0)  # fmt: skip
        parent = body
    poses = mjflex.reference_body_poses(spec)
    for i in range(1, n):
        xpos = poses[0][poses[2].index(f"link{i}")]
        mjflex.add_flexure(spec, f"flex{i}", f"link{i - 1}", f"link{i}", pos=xpos + [0.005, 0.002, 0.0],
                           quat=[1, 0.1, 0.2, 0.0], K=K, B=B, method=method, poses=poses, terms=terms,
                           kind=kind)  # fmt: skip
    return spec


def set_initial_motion(model, data, seed=0, scale=1.0):
    """A reproducible initial velocity (and for free bodies a relative rotation) of size ``scale``."""
    rng = np.random.default_rng(seed)
    data.qvel[:] = scale * rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)


def _start_spec(name, integrator="RK4", timestep=1e-3):
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.timestep = timestep
    spec.option.gravity = [0, 0, 0]
    return spec


def _block(parent, name, pos, mass, inertia, **kwargs):
    """A body with explicit principal inertia at its origin and a massless, non-colliding marker geom."""
    body = parent.add_body(name=name, pos=pos, mass=mass, inertia=inertia, ipos=[0, 0, 0], iquat=[1, 0, 0, 0],
                           **kwargs)  # fmt: skip
    body.explicitinertial = True
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0, 0], contype=0, conaffinity=0, mass=0, density=0)
    return body


def slide_oscillator_spec(*, k=1e4, mass=1.0, v0=1.0, B=None, timestep=1e-3):
    """A block on a slide joint along x tied to the world by one flexure ``spring``: ``omega = sqrt(k / m)``.

    The element is at the block's origin, so the slide moves it in pure translation and the
    twist is exactly ``(0, 0, 0, x, 0, 0)``: a linear oscillator for either method. Keyframe
    ``push`` starts it at ``x = 0`` with velocity ``v0`` [m/s].
    """
    spec = _start_spec("oscillator", timestep=timestep)
    block = _block(spec.worldbody, "block", [0, 0, 0], mass, [1e-3, 1e-3, 1e-3])
    block.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    mjflex.add_flexure(spec, "spring", "world", "block", pos=[0, 0, 0], K=[1.0, 1.0, 1.0, k, k, k], B=B)
    spec.add_key(name="push", qvel=[v0])
    return spec


ARM = {"length": 0.1, "mass": 0.027, "inertia": (1.0e-6, 2.5e-5, 2.5e-5), "k_z": 0.1, "k_rot": 1e3, "k_t": 1e6}


def pivot_arm_spec(*, omega0=3.0, timestep=1e-4):
    """A free arm pinned to the world at one end by a flexure ``pivot`` compliant about z only.

    The arm (``ARM``) lies along x with its centre of mass at ``(length / 2, 0, 0)``; the element
    frame is its end at the origin. Keyframe ``swing`` rotates it about the pivot's z axis at
    ``omega0`` [rad/s]. Its lowest elastic mode is close to ``sqrt(k_z / I_pivot)`` (exact for an
    infinitely stiff element in the other five directions).
    """
    a = ARM
    spec = _start_spec("pivot_arm", timestep=timestep)
    arm = _block(spec.worldbody, "arm", [a["length"] / 2, 0, 0], a["mass"], a["inertia"])
    arm.add_freejoint()
    k = [a["k_rot"], a["k_rot"], a["k_z"], a["k_t"], a["k_t"], a["k_t"]]
    mjflex.add_flexure(spec, "pivot", "world", "arm", pos=[0, 0, 0], K=k)
    spec.add_key(name="swing", qvel=[0, omega0 * a["length"] / 2, 0, 0, 0, omega0])
    return spec


def hinge_arm_variant(model):
    """The pivot arm with its flexure replaced by a hinge joint about z with stiffness ``k_z``.

    A real pseudo-rigid-body model: a real MuJoCo model whose state map takes the arm's
    rotation angle and rate about z from the full model's free joint.
    """
    from mjflex.variants.variant import Variant

    a = ARM
    spec = _start_spec("pivot_arm_hinge", timestep=model.opt.timestep)
    arm = _block(spec.worldbody, "arm", [a["length"] / 2, 0, 0], a["mass"], a["inertia"])
    arm.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], pos=[-a["length"] / 2, 0, 0], stiffness=a["k_z"])
    variant_model = spec.compile()

    def state_from(source_model, source_data):
        body = mujoco.mj_name2id(source_model, mujoco.mjtObj.mjOBJ_BODY, "arm")
        q = source_data.xquat[body]
        w = source_data.qvel[source_model.jnt_dofadr[source_model.body_jntadr[body]] + 5]
        return np.array([2.0 * np.arctan2(q[3], q[0])]), np.array([w])

    return Variant("hinge", variant_model, "flexure 'pivot' -> hinge about z with its k_z; rigid elsewhere",
                   {"arm": ("arm", np.eye(4))}, state_from)  # fmt: skip


def demo_terms(method, order=4, seed=0):
    """Polynomial terms that change K_DEMO's energy by ~10-20 % at 0.2 rad / 2 cm (random signs).

    Each term is at most ``0.3 / sqrt(M)`` of the quadratic energy ``U0`` there, so their sum is ~0.2 ``U0``
    (for dual quaternions with ``s'`` taken as 0.01, beyond what these motions reach: its terms stay small,
    and so the dynamics tests stay stable).
    """
    rng = np.random.default_rng(seed)
    e = mjflex.polynomial_basis(method, order)
    rot, trans = 0.2, 0.02
    z = [rot] * 3 + [trans] * 3 if method == "twist" else [1.0, *[rot / 2] * 3, 0.01, *[trans / 2] * 3]
    U0 = 0.5 * (0.6 * rot**2 + 100.0 * trans**2)
    r = rng.uniform(-1.0, 1.0, len(e)) * 0.3 / np.sqrt(len(e))
    return mjflex.PolynomialTerms(method, e, r * U0 / np.prod(np.array(z) ** e, axis=1))


def perturb_joints(model, data, rng, *, angle=0.3, other=0.4):
    """Random joint positions around ``qpos0`` (ball joints: a unit quaternion near identity) and velocities."""
    data.qpos[:] = model.qpos0
    for j in range(model.njnt):
        adr = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            dq = np.r_[1.0, angle * rng.normal(size=3)]
            data.qpos[adr : adr + 4] = dq / np.linalg.norm(dq)
        else:
            data.qpos[adr] = other * rng.normal()
    data.qvel[:] = rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)


def applied_wrenches_reference(model, data, flex):
    """Generalized forces of the provider's wrenches through MuJoCo's own ``mj_applyFT`` (the independent path)."""
    W = flex.wrenches(data)
    expected = np.zeros(model.nv)
    for e in range(len(flex)):
        sa, sb = flex.site_ids[e]
        point = data.site_xpos[sb]
        mujoco.mj_applyFT(model, data, W[e, 3:], W[e, :3], point, model.site_bodyid[sb], expected)
        mujoco.mj_applyFT(model, data, -W[e, 3:], -W[e, :3], point, model.site_bodyid[sa], expected)
    return expected


def rollout_and_serial(model, data, nstep, *, copies=4, threads=2):
    """``(states, final)``: ``mujoco.rollout`` of ``copies`` copies on ``threads`` threads, and serial stepping.

    Both start from ``data``'s state and run while the caller has a provider installed.
    """
    from mujoco import rollout

    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data, state0, kind)
    states, _ = rollout.rollout([model] * copies, [mujoco.MjData(model) for _ in range(threads)],
                                np.tile(state0, (copies, 1)), nstep=nstep)  # fmt: skip
    for _ in range(nstep):
        mujoco.mj_step(model, data)
    final = np.empty_like(state0)
    mujoco.mj_getState(model, data, final, kind)
    return states, final
