"""Small MuJoCo models built with MjSpec for the tests of the MuJoCo layer."""

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


def two_body_spec(*, method="twist", K=K_DEMO, B=None, integrator="RK4", timestep=1e-3, gravity=False, terms=None):
    """Bodies A and B on free joints joined at their midpoint by one flexure named ``link``."""
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
                       terms=terms)  # fmt: skip
    return spec


def hinge_chain_spec(*, n=3, K=K_DEMO, B=None, method="twist", integrator="RK4", timestep=1e-3, terms=None):
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
                           quat=[1, 0.1, 0.2, 0.0], K=K, B=B, method=method, poses=poses, terms=terms)  # fmt: skip
    return spec


def set_initial_motion(model, data, seed=0, scale=1.0):
    """A reproducible initial velocity (and for free bodies a relative rotation) of size ``scale``."""
    rng = np.random.default_rng(seed)
    data.qvel[:] = scale * rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)


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
