"""Models and references for the MuJoCo Warp tests (tests/test_warp*.py)."""

import warnings

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import random_spd
from tests.plugin_models import polynomial_terms


def features_model(kind="record", stops=False):
    """:func:`features_xml` compiled."""
    return mujoco.MjModel.from_xml_string(features_xml(kind, stops))


N, INF = None, np.inf
#: End stops of the features model's elements (``features_xml(stops=True)``), by element: limits on rotations of
#: 0.3 ... 2 rad and on positions of 3 ... 80 mm, one- and two-sided, derived and given stiffness, so that random
#: states of up to 2.5 rad engage some and leave others free; e5 and e10 have none (elements without stops beside
#: elements with them); e6 is disabled (its stops do nothing).
STOPS = {
    "e0": mjflex.Stops(lower=[-0.6, -0.6, -0.6, N, N, N], upper=[0.6, 0.6, 0.6, N, N, N]),
    "e1": mjflex.Stops(lower=[N, N, N, -0.01, N, N], upper=[0.4, N, 1.0, N, N, N], stiffness=50.0),
    "e2": mjflex.Stops(
        lower=[N, N, N, -0.005, -0.02, -INF], upper=[N, N, N, 0.005, 0.02, 0.003], stiffness=[0, 0, 0, 2e4, 1e4, 3e4]
    ),
    "e3": mjflex.Stops(lower=[-0.8, N, -0.3, N, N, N], upper=[0.8, 1.0, 0.3, N, N, N]),
    "e4": mjflex.Stops(lower=[-1.0, N, N, -0.02, N, N], upper=[1.0, N, 1.0, N, 0.025, N]),
    "e6": mjflex.Stops(upper=[1.0, 1.0, 1.0, 0.03, 0.03, 0.03]),
    "e7": mjflex.Stops(lower=[-1.0, -0.4, N, N, -0.008, N], upper=[1.0, N, 0.5, 0.008, N, N], stiffness=30.0),
    "e8": mjflex.Stops(lower=[-0.3, -0.3, -0.3, N, N, N], upper=[0.3, 0.3, 0.3, N, N, N]),
    "e9": mjflex.Stops(lower=[-0.5, N, -0.5, -0.01, N, N], upper=[0.2, 0.4, N, N, 0.01, N]),
    "planar": mjflex.Stops(lower=[-2.0, N, -0.05], upper=[2.0, 0.08, N]),
}


def features_xml(kind="record", stops=False):
    """MJCF text of every element feature the Warp kernels implement, in one model.

    Six free boxes and the world joined by twist and dual-quaternion elements (diagonal and full K
    and B, no damping, polynomial terms of both methods, grounded, disabled); a chain hanging from
    the world (hinge; slide and hinge; ball) with elements between links and to a free box (dof
    chains on one or both sides); two bodies on planar joints (slide x, slide y, hinge z) joined by
    a planar element. Written out and read back, so that 6-digit site poses leave rest offsets.
    ``kind``: how the elements are written ("record" or "plugin"); ``stops``: with the end stops of ``STOPS``
    (True), or of a dict of the same form.
    """
    stops = STOPS if stops is True else (stops or {})
    rng = np.random.default_rng(26)
    spec = mujoco.MjSpec()
    spec.modelname = "features"
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = 1e-4
    for i in range(6):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.05 * i, 0.01 * np.sin(i), 0.2],
                                       quat=Rotation.random(random_state=rng).as_quat(scalar_first=True))  # fmt: skip
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.005, 0.01], density=2700, contype=0,
                      conaffinity=0)  # fmt: skip
    parent = spec.worldbody
    for i in range(3):
        link = parent.add_body(name=f"link{i}", pos=[0.0, 0.0, -0.1] if i else [0.0, 0.3, 0.4])
        if i == 0:
            link.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], pos=[0, 0, 0.05])
        elif i == 1:
            link.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
            link.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 1], pos=[0.01, 0, 0])
        else:
            link.add_joint(type=mujoco.mjtJoint.mjJNT_BALL)
        link.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0.02, 0, -0.08], size=[0.01, 0, 0],
                      density=2000, contype=0, conaffinity=0)  # fmt: skip
        parent = link
    for name, x in (("pA", 0.0), ("pB", 0.1)):
        body = spec.worldbody.add_body(name=name, pos=[x, -0.3, 0.0])
        for axis in ([1, 0, 0], [0, 1, 0]):
            body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
        body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.01, 0.01], density=1000, contype=0,
                      conaffinity=0)  # fmt: skip
    poses = mjflex.reference_body_poses(spec)
    where = dict(zip(poses[2], poses[0], strict=True))
    diag = np.diag([0.6, 0.8, 0.5, 3e3, 4e3, 2e3])
    full = random_spd(rng, cond=1e3, scales=[1, 1, 1, 60, 60, 60])
    layout = [  # (body a, body b, method, K, B, extra)
        ("b0", "b1", "twist", diag, 1e-3 * diag, {}),
        ("b1", "b2", "dualquat", full, 2e-3 * full, {}),
        ("b2", "b3", "dualquat", full, None, {}),
        ("b3", "b4", "twist", full, 1e-3 * full, {"terms": polynomial_terms("twist", scale=2.0)}),
        ("b4", "b5", "dualquat", diag, 1e-3 * diag, {"terms": polynomial_terms("dualquat", scale=2.0)}),
        ("world", "b0", "twist", diag, 1e-3 * diag, {}),
        ("b0", "b2", "twist", diag, 1e-3 * diag, {"enabled": False}),
        ("b5", "b1", "twist", full, 1e-3 * full, {"viscous": False}),
        ("link0", "link1", "twist", full, 1e-3 * full, {}),
        ("link1", "link2", "dualquat", diag, 1e-3 * diag, {}),
        ("link2", "b3", "twist", diag, 1e-3 * diag, {}),
    ]
    for e, (a, b, method, K, B, extra) in enumerate(layout):
        pa = where.get(a, np.zeros(3))
        with warnings.catch_warnings():  # e8, e9 act in parallel with the chain's joints: on purpose (dof chains)
            warnings.simplefilter("ignore", mjflex.LikelyMistakeWarning)
            mjflex.add_flexure(spec, f"e{e}", a, b, pos=0.5 * (pa + where[b]),
                               quat=Rotation.random(random_state=rng).as_quat(scalar_first=True), K=K, B=B,
                               method=method, poses=poses, kind=kind, stops=stops.get(f"e{e}"),
                               **extra)  # fmt: skip
    Kp = np.array([[0.4, 0.02, -0.01], [0.02, 90.0, 4.0], [-0.01, 4.0, 120.0]])
    mjflex.add_flexure(spec, "planar", "pA", "pB", pos=[0.05, -0.3, 0.0], quat=[0.9, 0, 0, 0.3], K=Kp, B=0.02 * Kp,
                       poses=poses, kind=kind, stops=stops.get("planar"))  # fmt: skip
    return spec.to_xml()


def random_state(model, rng, *, angle=1.0, shift=0.005, speed=1.0):
    """qpos, qvel: each free body turned by up to ``angle`` rad and shifted by ``shift`` m, the other joints moved
    (ball joints turned by up to ``angle``), random velocities of size ``speed``."""
    qpos = model.qpos0.copy()
    free, ball, hinge = (int(t) for t in (mujoco.mjtJoint.mjJNT_FREE, mujoco.mjtJoint.mjJNT_BALL,
                                          mujoco.mjtJoint.mjJNT_HINGE))  # fmt: skip
    for j in range(model.njnt):
        adr, kind = int(model.jnt_qposadr[j]), int(model.jnt_type[j])
        if kind in (free, ball):
            a = adr + 3 if kind == free else adr
            if kind == free:
                qpos[adr : adr + 3] += shift * rng.normal(size=3)
            turn = Rotation.from_rotvec(rng.uniform(0, angle) * Rotation.random(random_state=rng).as_rotvec() / np.pi)
            qpos[a : a + 4] = (turn * Rotation.from_quat(qpos[a : a + 4], scalar_first=True)).as_quat(scalar_first=True)
        else:
            qpos[adr] += (angle if kind == hinge else shift) * rng.uniform(-1, 1)
    return qpos, speed * rng.normal(size=model.nv)
