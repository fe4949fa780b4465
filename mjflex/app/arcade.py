"""The ARCADE-like flexural linear guide of the paper (sec. 6), built with MjSpec.

Topology (our design; the paper gives only the counts). Three identical linkage plates lie
in radial planes at 0, 120 and 240 degrees around the cylinder axis ``z``. In its plate, with
``r`` the radial coordinate:

* the **hub** (the plate's six-joint link) is a bar parallel to the axis;
* two **rods** (one link, two notch hinges each) join the hub to two lugs on the **cylinder**
  at ``z = +-z_rod``: a parallelogram that guides the cylinder along ``z`` relative to the hub;
* four **legs** (two links in line, three flexures each: notch at the hub, notch in the middle,
  leaf spring at the base) join the hub to the **base** frame at ``z = +-z_leg1, +-z_leg2``:
  parallel radial rods to first order, which guide the hub along ``z`` relative to the base.

All flexures bend about the plate normal, so each plate is a planar mechanism whose only
soft in-plane motion (apart from the legs' light internal modes) is the axial one; the three
plates at 120 degrees stiffen each other against every other cylinder motion, and their
second-order (arc) parasitic motions cancel by symmetry, keeping the guide straight.

Counts: bodies 1 base + 1 cylinder + 3 x (1 hub + 2 rods + 8 leg links) = 35; flexures per
plate 4 (rods) + 8 (legs) = 12 notch hinges and 4 leaf springs, i.e. 36 and 12; the hubs carry
6 joints, rods and leg links 2, the cylinder 6 and the base 12. The variant
``rigid_end_groups=True`` welds the three inner leg links closest to each end plate into one
body (the paper's remark that "the three bodies near each end plate" were meant to be rigidly
attached), giving 31 bodies and the same flexures.

Parameters are the paper's: aluminium links 2700 kg/m^3 with 0.5 cm x 0.95 cm section;
cylinder r 1.9 cm, L 19.7 cm at 10 % of that density; base with the inertia of a uniform
cylinder r 19 cm, L 197 cm at 10 % density (60 kg; the paper calls it "100 times" the inner
cylinder, its dimensions give 1000 times); hinges and leaves with E 5 % of aluminium's
(3.5 GPa) and aluminium's Poisson ratio; notch holes 0.8 cm diameter, web 0.05 cm; leaves
0.9 cm x 0.05 cm; width 0.95 cm (the plate thickness).
"""

import os
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..geometry import bending_strain_per_radian, leaf_spring_stiffness, notch_hinge_stiffness
from ..mjcf.build import HIDDEN_SITE_GROUP, SHAPE_SITE_GROUP, add_flexure
from ..mjcf.spec import reference_body_poses

ALUMINIUM = 2700.0
E_ALUMINIUM = 70e9
NU_ALUMINIUM = 0.33


@dataclass
class ArcadeParams:
    """Dimensions [m], materials and damping of the ARCADE model (defaults: the paper's)."""

    link_width: float = 0.005
    plate_thickness: float = 0.0095
    link_density: float = ALUMINIUM
    cylinder_radius: float = 0.019
    cylinder_length: float = 0.197
    cylinder_density: float = 0.1 * ALUMINIUM
    base_radius: float = 0.19
    base_length: float = 1.97
    base_density: float = 0.1 * ALUMINIUM
    E: float = 0.05 * E_ALUMINIUM
    nu: float = NU_ALUMINIUM
    notch_radius: float = 0.004
    notch_web: float = 0.0005
    leaf_length: float = 0.009
    leaf_thickness: float = 0.0005
    # layout in the plate (r, z)
    rod_z: float = 0.050
    leg_z: tuple = (0.090, 0.065)
    r_rod_inner: float = 0.033  # hinge centres
    r_rod_outer: float = 0.063
    r_hub: float = 0.0695  # hub bar centre line
    r_leg_inner: float = 0.076
    r_leg_middle: float = 0.106
    r_leaf: float = 0.1355  # leaf centre
    # stiffness-proportional (Rayleigh) damping B = beta K [s]
    damping_beta: float = 2e-6
    plate_angles_deg: tuple = field(default=(0.0, 120.0, 240.0))

    @property
    def r_base(self) -> float:
        return self.r_leaf + 0.5 * self.leaf_length


def notch_stiffness(p: ArcadeParams, method="table") -> np.ndarray:
    """Stiffness of the paper's notch hinge in its own frame (x along the link, z the hinge axis).

    ``method``: of :func:`mjflex.geometry.notch_hinge_stiffness` (default: the 3-D
    finite-element table, blocks of the hinge's own height subtracted; ``"beam"``: the
    closed-form beam model the model used before).
    """
    return notch_hinge_stiffness(p.notch_radius, p.notch_web, p.plate_thickness, p.E, p.nu, method=method)


def leaf_stiffness(p: ArcadeParams, method="table") -> np.ndarray:
    """Stiffness of the paper's leaf spring at its centre (blocks 10 t high: the link is 10 leaf thicknesses wide)."""
    return leaf_spring_stiffness(p.leaf_length, p.leaf_thickness, p.plate_thickness, p.E, p.nu, method=method)


def _plate_frame(angle):
    """World position of plate point (r, z) and the hinge-frame quaternion (x radial, z = plate normal)."""
    c, s = np.cos(angle), np.sin(angle)
    e_r, e_t, e_z = np.array([c, s, 0.0]), np.array([-s, c, 0.0]), np.array([0.0, 0.0, 1.0])
    R = np.column_stack([e_r, np.cross(e_t, e_r), e_t])
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, R.ravel())
    return (lambda r, z: r * e_r + z * e_z), q


def _box(body, name, center, half, quat, density, rgba):
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=center, size=half, quat=quat, density=density,
                  rgba=rgba, contype=0, conaffinity=0)  # fmt: skip


def _link(spec, name, p, pos, quat, half_r, half_z, rgba=(0.72, 0.74, 0.78, 1.0)):
    """A free body at ``pos``: a box of half sizes ``half_r`` (radial), ``half_z`` (axial) in the plate."""
    body = spec.worldbody.add_body(name=name, pos=pos, quat=quat)
    body.add_freejoint()
    _box(body, name + "_geom", [0, 0, 0], [half_r, half_z, 0.5 * p.plate_thickness], [1, 0, 0, 0], p.link_density, rgba)


def _radial_link(spec, name, p, at, quat, r0, r1, z):
    """A free body: box between radii r0..r1 at height z of the plate (section link_width x plate_thickness)."""
    _link(spec, name, p, at(0.5 * (r0 + r1), z), quat, 0.5 * (r1 - r0), 0.5 * p.link_width)


def _scenery(spec):
    """Sky, lights: the model renders well with MuJoCo's default free camera."""
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.55, 0.6, 0.7], rgb2=[0.08, 0.09, 0.12], width=256, height=1536)  # fmt: skip
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    spec.worldbody.add_light(name="key", pos=[0.4, -0.6, 0.8], dir=[-0.4, 0.6, -0.8], diffuse=[0.6, 0.6, 0.6],
                             castshadow=False)  # fmt: skip


def _base(spec, p):
    body = spec.worldbody.add_body(name="base", mass=p.base_density * np.pi * p.base_radius**2 * p.base_length,
                                   ipos=[0, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
    m = body.mass
    body.inertia = [m * (3 * p.base_radius**2 + p.base_length**2) / 12] * 2 + [m * p.base_radius**2 / 2]
    body.explicitinertial = True
    body.add_freejoint()
    half_z = max(p.leg_z) + 0.015
    color = (0.25, 0.27, 0.32, 1.0)
    for k, deg in enumerate(p.plate_angles_deg):
        at, quat = _plate_frame(np.radians(deg))
        _box(body, f"base_post_p{k}", at(p.r_base + 0.005, 0.0), [0.005, half_z, 0.006], quat, 0, color)
    # the two quasi-triangular end plates, as flat triangular meshes
    tri = [np.radians(d) for d in p.plate_angles_deg]
    verts = []
    for z0 in (-0.003, 0.003):
        for a in tri:
            verts += [(p.r_base + 0.02) * np.cos(a), (p.r_base + 0.02) * np.sin(a), z0]
    spec.add_mesh(name="end_plate", uservert=verts)
    for name, z in (("base_end_top", half_z + 0.003), ("base_end_bottom", -half_z - 0.003)):
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname="end_plate", pos=[0, 0, z],
                      density=0, mass=0, rgba=(0.3, 0.32, 0.38, 0.6), contype=0, conaffinity=0)  # fmt: skip
    return body


def _cylinder(spec, p):
    body = spec.worldbody.add_body(name="cylinder")
    body.add_freejoint()
    body.add_geom(name="cylinder_shell", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                  size=[p.cylinder_radius, 0.5 * p.cylinder_length, 0], density=p.cylinder_density,
                  rgba=(0.35, 0.55, 0.85, 1.0), contype=0, conaffinity=0)  # fmt: skip
    lug_r0 = p.cylinder_radius
    lug_r1 = p.r_rod_inner - p.notch_radius
    for k, deg in enumerate(p.plate_angles_deg):
        at, quat = _plate_frame(np.radians(deg))
        for side, z in (("top", p.rod_z), ("bottom", -p.rod_z)):
            _box(body, f"cylinder_lug_p{k}_{side}", at(0.5 * (lug_r0 + lug_r1), z),
                 [0.5 * (lug_r1 - lug_r0), 0.5 * p.link_width, 0.5 * p.plate_thickness], quat, p.link_density,
                 (0.35, 0.55, 0.85, 1.0))  # fmt: skip
    return body


def _plate(spec, p, k):
    """Bodies of plate k; returns its flexure elements: (name, body a, body b, position, quaternion, kind)."""
    at, quat = _plate_frame(np.radians(p.plate_angles_deg[k]))
    hub = f"hub_p{k}"
    _link(spec, hub, p, at(p.r_hub, 0.0), quat, 0.5 * p.link_width, max(p.leg_z) + 0.5 * p.link_width,
          (0.85, 0.6, 0.3, 1.0))  # fmt: skip
    R = p.notch_radius
    elements = []
    for tag, z in (("R1", p.rod_z), ("R2", -p.rod_z)):
        rod = f"rod_p{k}_{tag}"
        _radial_link(spec, rod, p, at, quat, p.r_rod_inner + R, p.r_rod_outer - R, z)
        elements += [(f"notch_p{k}_{tag}_cyl", "cylinder", rod, at(p.r_rod_inner, z), quat, "notch"),
                     (f"notch_p{k}_{tag}_hub", rod, hub, at(p.r_rod_outer, z), quat, "notch")]  # fmt: skip
    leg_levels = (("L1", p.leg_z[0]), ("L2", p.leg_z[1]), ("L3", -p.leg_z[1]), ("L4", -p.leg_z[0]))
    for tag, z in leg_levels:
        inner, outer = f"leg_p{k}_{tag}_in", f"leg_p{k}_{tag}_out"
        _radial_link(spec, inner, p, at, quat, p.r_leg_inner + R, p.r_leg_middle - R, z)
        _radial_link(spec, outer, p, at, quat, p.r_leg_middle + R, p.r_leaf - 0.5 * p.leaf_length, z)
        elements += [
            (f"notch_p{k}_{tag}_hub", hub, inner, at(p.r_leg_inner, z), quat, "notch"),
            (f"notch_p{k}_{tag}_mid", inner, outer, at(p.r_leg_middle, z), quat, "notch"),
            (f"leaf_p{k}_{tag}_base", outer, "base", at(p.r_leaf, z), quat, "leaf"),
        ]
    return elements


def _weld_end_groups(spec, p):
    """Merge the three inner links of the legs next to each end plate into one body (the variant)."""
    renames = {}
    for ring, tag in (("ring_top", "L1"), ("ring_bottom", "L4")):
        new = spec.worldbody.add_body(name=ring)
        new.add_freejoint()
        for k in range(len(p.plate_angles_deg)):
            old = spec.body(f"leg_p{k}_{tag}_in")
            geom = old.first_geom()
            kept = {"name": geom.name, "type": geom.type, "size": geom.size.copy(), "density": geom.density,
                    "rgba": geom.rgba.copy(), "pos": old.pos.copy(), "quat": old.quat.copy()}  # fmt: skip
            spec.delete(old)
            new.add_geom(contype=0, conaffinity=0, **kept)
            renames[f"leg_p{k}_{tag}_in"] = ring
    return renames


def build_arcade_spec(params: ArcadeParams | None = None, *, method="twist", rigid_end_groups=False, kind="plugin"):
    """MjSpec of the ARCADE-like guide with its 48 flexures (module docstring).

    Parameters
    ----------
    params : ArcadeParams, optional
        Dimensions, materials and damping; default the paper's.
    method : {"twist", "dualquat"}
        Method stored for every element.
    rigid_end_groups : bool
        The paper's variant: the three bodies near each end plate rigidly joined (31 bodies).
    kind : {"plugin", "record"}
        How the elements are written (:func:`mjflex.add_flexure`): engine-plugin instances
        (default; the model runs in any MuJoCo program) or text records.
    """
    p = params or ArcadeParams()
    spec = mujoco.MjSpec()
    spec.modelname = "arcade_rigid" if rigid_end_groups else "arcade"
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = 1e-5
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 1280, 720
    spec.stat.center = [0, 0, 0]
    spec.stat.extent = 0.3
    _scenery(spec)
    _base(spec, p)
    _cylinder(spec, p)
    elements = []
    for k in range(len(p.plate_angles_deg)):
        elements += _plate(spec, p, k)
    renames = _weld_end_groups(spec, p) if rigid_end_groups else {}
    kinds = _flexure_kinds(p)
    poses = reference_body_poses(spec)
    for name, a, b, pos, quat, flexure in elements:
        K, strain, source = kinds[flexure]
        h = add_flexure(spec, name, renames.get(a, a), renames.get(b, b), pos=pos, quat=quat, K=K,
                        B=p.damping_beta * K, method=method, poses=poses, strain_per_radian=strain, source=source,
                        kind=kind, strain_scale=STRAIN_SCALE)  # fmt: skip
        _style_sites(h, p, flexure)
    _paper_keyframe(spec)
    return spec


def _flexure_kinds(p):
    """Stiffness, strain per radian and provenance of the two flexure kinds."""
    material = {"E": p.E, "nu": p.nu}
    notch = {"kind": "circular notch hinge", "R": p.notch_radius, "t": p.notch_web, "b": p.plate_thickness,
             **material, "formula": "mjflex.geometry.notch_hinge_stiffness (3-D FE table)"}  # fmt: skip
    leaf = {"kind": "leaf spring", "L": p.leaf_length, "t": p.leaf_thickness, "b": p.plate_thickness, **material,
            "formula": "mjflex.geometry.leaf_spring_stiffness (3-D FE table, blocks 10 t high)"}  # fmt: skip
    K_n, K_l = notch_stiffness(p), leaf_stiffness(p)
    return {
        "notch": (K_n, bending_strain_per_radian(K_n, p.notch_web, p.plate_thickness, p.E, p.nu), notch),
        "leaf": (K_l, bending_strain_per_radian(K_l, p.leaf_thickness, p.plate_thickness, p.E, p.nu), leaf),
    }


#: Full scale of the flexures' strain colours in MuJoCo's viewer (the engine plugin's drawing): 2 %, about the
#: paper run's peak bending strain (2.1 %), so that the viewer's colours read like the demo's panels; the
#: hinges' material (5 % of aluminium's modulus, 3.5 GPa, a polymer) stays elastic to a few percent.
STRAIN_SCALE = 0.02

PAPER_SPIN = 105.0  # rad/s, about the long axis (1000 rpm)
PAPER_AXIAL_SPEED = 5.0  # m/s, of the cylinder along its axis


def _paper_keyframe(spec):
    """Keyframe ``paper_run``: the initial condition of the paper's simulation (sec. 6)."""
    model = spec.compile()
    data = mujoco.MjData(model)
    rigid_spin_velocity(model, data, PAPER_SPIN, PAPER_AXIAL_SPEED)
    spec.add_key(name="paper_run", qpos=model.qpos0, qvel=data.qvel.copy())


def _style_sites(handle, p, kind):
    """Draw the flexure as a thin box on site a; hide site b (site groups of :mod:`mjflex.mjcf.build`)."""
    x, y = (p.notch_radius, 0.5 * p.notch_web) if kind == "notch" else (0.5 * p.leaf_length, 0.5 * p.leaf_thickness)
    handle.site_a.type = mujoco.mjtGeom.mjGEOM_BOX
    handle.site_a.size = [x, max(y, 0.0006), 0.5 * p.plate_thickness * 1.02]
    handle.site_a.group = SHAPE_SITE_GROUP
    handle.site_a.rgba = [0.2, 0.8, 0.3, 1.0]
    handle.site_b.group = HIDDEN_SITE_GROUP


def rigid_spin_velocity(model, data, omega, axial_speed, body="cylinder"):
    """The paper's initial condition: rigid spin ``omega`` [rad/s] about ``z`` plus ``axial_speed`` [m/s] of ``body``.

    Writes ``data.qvel`` for a model whose bodies are all free-jointed children of the world.
    """
    mujoco.mj_kinematics(model, data)
    w = np.array([0.0, 0.0, omega])
    for b in range(1, model.nbody):
        j = model.body_jntadr[b]
        adr = model.jnt_dofadr[j]
        data.qvel[adr : adr + 3] = np.cross(w, data.xpos[b])
        data.qvel[adr + 3 : adr + 6] = data.xmat[b].reshape(3, 3).T @ w
    cyl = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
    data.qvel[model.jnt_dofadr[model.body_jntadr[cyl]] + 2] += axial_speed
    mujoco.mj_forward(model, data)


__all__ = ["ArcadeParams", "build_arcade_spec", "leaf_stiffness", "notch_stiffness", "rigid_spin_velocity"]


#: The models/ folder of a source checkout (absent from an installed wheel: the model is built in memory then).
REPO_MODELS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "models")


def arcade_source():
    """``(source, label)``: the path of ``models/arcade.xml`` in the source tree, or an ``MjSpec`` of the same model.

    Its elements are plugin instances.
    """
    path = os.path.join(REPO_MODELS, "arcade.xml")
    if os.path.exists(path):
        return path, path
    return build_arcade_spec(), "arcade (built in memory)"


def arcade_model():
    """``(MjModel, label)`` of :func:`arcade_source`."""
    source, label = arcade_source()
    model = mujoco.MjModel.from_xml_path(source) if isinstance(source, str) else source.compile()
    return model, label
