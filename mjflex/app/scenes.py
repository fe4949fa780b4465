"""Small benchmark scenes with flexures: a bushing, a cantilevered beam as a chain, a parallelogram.

They are the scenes of ``scripts/compare_alternatives.py`` and of the tests of the reductions and
the MuJoCo-native alternatives; each is an ``MjSpec`` built with :func:`mjflex.add_flexure`, whose
bodies are free bodies as mjflex models are, with a keyframe holding its initial state.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from ..geometry import leaf_spring_stiffness, notch_hinge_stiffness
from ..geometry.sections import shear_constants
from ..mjcf.build import add_flexure
from ..mjcf.spec import reference_body_poses

ALUMINIUM = 2700.0


def _spec(name, timestep, integrator="RK4"):
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.option.gravity = [0, 0, 0]
    spec.option.timestep = timestep
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    return spec


def _box_body(parent, name, pos, half, density, quat=(1, 0, 0, 0), free=True):
    body = parent.add_body(name=name, pos=pos, quat=quat)
    if free:
        body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=half, density=density, contype=0, conaffinity=0)
    return body


def _add_key(spec, name, body, velocity):
    """Keyframe ``name``: the reference pose, with the first ``len(velocity)`` dofs of ``body``'s free joint
    (linear velocity in world axes [m/s], then angular velocity [rad/s]) set to ``velocity``; returns ``spec``."""
    model = spec.compile()
    qvel = np.zeros(model.nv)
    adr = model.jnt_dofadr[model.body(body).jntadr[0]]
    qvel[adr : adr + len(velocity)] = velocity
    spec.add_key(name=name, qpos=model.qpos0, qvel=qvel)
    return spec


# ------------------------------------------------------------------------------------------ bushing

#: A rubber-like bushing with coupled rotation/translation stiffness (element frame at the body
#: origin): rows [rot x, rot y, rot z, x, y, z], N m/rad, N/rad, N/m.
BUSHING_K = np.array([
    [40.0, 2.0, -1.0, 0.0, 50.0, 0.0],
    [2.0, 55.0, 3.0, -60.0, 0.0, 10.0],
    [-1.0, 3.0, 25.0, 0.0, -20.0, 0.0],
    [0.0, -60.0, 0.0, 4.0e4, 1.0e3, 0.0],
    [50.0, 0.0, -20.0, 1.0e3, 3.0e4, -2.0e3],
    [0.0, 10.0, 0.0, 0.0, -2.0e3, 6.0e4],
])  # fmt: skip


def bushing_spec(*, K=BUSHING_K, beta=2e-4, timestep=2e-5, spin=(90.0, -60.0, 135.0), velocity=(3.0, -2.0, 4.0)):
    """One 1.2 kg block on a bushing to the world, launched into a large combined rotation and translation.

    The keyframe ``launch`` gives the block an angular velocity ``spin`` [rad/s] and a velocity
    ``velocity`` [m/s] of its centre (world axes), enough for a rotation beyond 1 rad and
    translations of a few centimetres. ``B = beta K``.
    """
    spec = _spec("bushing", timestep)
    _box_body(spec.worldbody, "block", [0, 0, 0], [0.06, 0.04, 0.025], 2500.0)
    add_flexure(spec, "bushing", "world", "block", pos=[0, 0, 0], K=K, B=beta * np.asarray(K), method="twist")
    return _add_key(spec, "launch", "block", [*velocity, *spin])  # angular: body axes = world axes here


# ------------------------------------------------------------------------------------------ cantilever


@dataclass
class Beam:
    """A straight rectangular beam clamped at x = 0, lying along x (SI units).

    ``t`` is the thickness in the bending plane (y), ``b`` the width (z).
    """

    L: float = 0.1
    t: float = 0.002
    b: float = 0.01
    E: float = 70e9
    nu: float = 0.33
    density: float = ALUMINIUM

    @property
    def EI(self) -> float:
        return self.E * self.b * self.t**3 / 12.0

    @property
    def mass_per_length(self) -> float:
        return self.density * self.b * self.t

    def tip_deflection(self, F) -> float:
        """Linear tip deflection under an end load ``F`` [N] along y: bending plus shear [m]."""
        G, kappa = shear_constants(self.E, self.nu)
        return F * self.L**3 / (3 * self.EI) + F * self.L / (kappa * G * self.b * self.t)

    def frequencies(self, count=3) -> np.ndarray:
        """Euler-Bernoulli cantilever frequencies [Hz] (bending in the x-y plane)."""
        beta_L = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910])[:count]
        return beta_L**2 * np.sqrt(self.EI / (self.mass_per_length * self.L**4)) / (2 * np.pi)


def cantilever_spec(beam=None, n=10, *, tip_speed=0.0, timestep=2e-6, beta=0.0):
    """The beam as a chain of ``n`` elements at the centres of ``n`` equal segments.

    Element ``seg{k}`` (at ``x = (k + 1/2) L/n``) carries the exact Timoshenko stiffness of its
    segment (:func:`mjflex.geometry.leaf_spring_stiffness` with the beam modulus ``E``, not the
    plate modulus of wide flexures, as in beam theory), so the chain's linear static tip
    deflection is the beam's for any ``n``; the mass is lumped into rigid bodies ``link1`` ...
    ``link{n}`` between the element points (the half segment at the clamp belongs to the
    world). Body ``link{n}`` carries the tip site ``tip``. Keyframe ``kick``: the tip body
    moving at ``tip_speed`` along y (0: at rest).
    """
    beam = beam or Beam()
    spec = _spec("cantilever", timestep)
    seg = beam.L / n
    edges = [0.5 * seg + k * seg for k in range(n)] + [beam.L]
    half_t = 0.5 * beam.t
    for k in range(1, n + 1):
        x0, x1 = edges[k - 1], edges[k]
        body = _box_body(spec.worldbody, f"link{k}", [0.5 * (x0 + x1), 0, 0], [0.5 * (x1 - x0), half_t, 0.5 * beam.b],
                         beam.density)  # fmt: skip
        if k == n:
            body.add_site(name="tip", pos=[0.5 * (x1 - x0), 0, 0])
    K = leaf_spring_stiffness(seg, beam.t, beam.b, beam.E, beam.nu, method="beam", wide=False, allow_out_of_range=True)
    poses = reference_body_poses(spec)
    for k in range(n):
        add_flexure(spec, f"seg{k}", "world" if k == 0 else f"link{k}", f"link{k + 1}", pos=[edges[k], 0, 0], K=K,
                    B=beta * K, poses=poses)  # fmt: skip
    return _add_key(spec, "kick", f"link{n}", [0.0, tip_speed])


def cantilever_flexcomp_spec(beam=None, n=10, *, timestep=2e-6):
    """The same beam as MuJoCo 4.0's 1-D ``flexcomp`` rod (discrete elastic rod, box section).

    ``n + 2`` points at ``x = -L/n, 0, L/n, ..., L``; the first two are pinned (``<pin id="0
    1"/>`` clamps the first edge, so the rod is clamped at ``x = 0``); inextensible edges
    (``<edge equality="true"/>``, as stiff as the step allows), Young's modulus and Poisson
    ratio of the beam, box section ``t x b`` (thin side in the bending plane x-y), lumped mass
    ``rho A L / n`` per free point.
    The tip is body ``rod_{n + 1}`` (a point mass, no orientation). Not a variant of the
    element chain: a flexcomp rod cannot join two moving bodies without equality constraints,
    and its vertices carry no orientation, so only the tip position is compared.
    """
    beam = beam or Beam()
    seg = beam.L / n
    points = " ".join(f"{(k - 1) * seg:.17g} 0 0" for k in range(n + 2))
    mass = beam.mass_per_length * seg * (n + 2)  # flexcomp divides by the number of points, pinned included
    xml = f"""<mujoco model="cantilever_flexcomp">
  <option timestep="{timestep}" gravity="0 0 0" integrator="RK4"/>
  <worldbody>
    <flexcomp name="rod" type="direct" dim="1" point="{points}" mass="{mass:.17g}">
      <elasticity young="{beam.E:.17g}" poisson="{beam.nu:.17g}" section="box"
                  sectionsize="{0.5 * beam.t:.17g} {0.5 * beam.b:.17g}"/>
      <edge equality="true" solref="{2 * timestep:.17g} 1" solimp="0.95 0.99 0.001 0.5 2"/>
      <contact contype="0" conaffinity="0"/>
      <pin id="0 1"/>
    </flexcomp>
  </worldbody>
</mujoco>"""
    return mujoco.MjSpec.from_string(xml)


# ------------------------------------------------------------------------------------------ parallelogram


def parallelogram_spec(*, speed=0.05, timestep=1e-5):
    """A planar parallelogram guide: two 4 cm rods on notch hinges carry a 6 cm platform.

    Four notch hinges (the ARCADE notch: R 4 mm, web 0.5 mm, width 9.5 mm, E 3.5 GPa) join the
    world (ground) to rods ``rod1``, ``rod2`` and these to the ``platform``: one closed loop.
    Keyframe ``push``: the platform moving at ``speed`` m/s along x (its guided direction).
    """
    spec = _spec("parallelogram", timestep)
    K = notch_hinge_stiffness(0.004, 0.0005, 0.0095, 3.5e9, 0.33)
    h, w = 0.04, 0.06
    quat = [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]  # element x along the rod (world y), z the hinge axis
    for i, x in enumerate((0.0, w)):
        _box_body(spec.worldbody, f"rod{i + 1}", [x, 0.5 * h, 0], [0.0025, 0.5 * h - 0.004, 0.00475], ALUMINIUM)
    _box_body(spec.worldbody, "platform", [0.5 * w, h, 0], [0.5 * w + 0.004, 0.0025, 0.00475], ALUMINIUM)
    poses = reference_body_poses(spec)
    for i, x in enumerate((0.0, w)):
        rod = f"rod{i + 1}"
        add_flexure(spec, f"notch{i + 1}_ground", "world", rod, pos=[x, 0, 0], quat=quat, K=K, B=2e-6 * K, poses=poses)
        add_flexure(spec, f"notch{i + 1}_top", rod, "platform", pos=[x, h, 0], quat=quat, K=K, B=2e-6 * K,
                    poses=poses)  # fmt: skip
    return _add_key(spec, "push", "platform", [speed])


__all__ = ["BUSHING_K", "Beam", "bushing_spec", "cantilever_flexcomp_spec", "cantilever_spec", "parallelogram_spec"]
