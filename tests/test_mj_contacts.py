"""Contacts between bodies joined by an element: excluded by add_flexure, reported by Flexures when they touch."""

import warnings

import mujoco
import numpy as np
import pytest

import mjflex

K = np.array([0.3, 40, 0.25, 5e6, 3e5, 1.5e6])
TOUCHING = "are\\s+in contact in the reference configuration"


def _two_blocks(gap=-0.002, parent_child=False):
    """Two 4 cm blocks end to end along x, overlapping by ``-gap`` [m] where the element joins them at x = 0."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    a = spec.worldbody.add_body(name="A", pos=[-0.02, 0, 0])
    a.add_freejoint()
    a.add_geom(name="ga", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.01, 0.01], density=2700)
    parent, pos = (a, [0.04 + gap, 0, 0]) if parent_child else (spec.worldbody, [0.02 + gap, 0, 0])
    b = parent.add_body(name="B", pos=pos)
    if parent_child:
        b.add_joint(type=mujoco.mjtJoint.mjJNT_BALL, pos=[-0.02 - gap, 0, 0])
    else:
        b.add_freejoint()
    b.add_geom(name="gb", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.01, 0.01], density=2700)
    return spec


def _contacts(model):
    data = mujoco.MjData(model)
    mujoco.mj_fwdPosition(model, data)
    return data.ncon


def _no_warning(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mjflex.Flexures(model)


def test_add_flexure_excludes_the_pair_by_default():
    spec = _two_blocks()
    assert _contacts(spec.compile()) > 0  # the blocks overlap where the element joins them
    mjflex.add_flexure(spec, "hinge", "A", "B", pos=[0, 0, 0], K=K)
    mjflex.add_flexure(spec, "second", "B", "A", pos=[0, 0.005, 0], K=K)  # same pair: excluded once
    model = spec.compile()
    assert model.nexclude == 1 and _contacts(model) == 0
    assert "<exclude body1=" in spec.to_xml()
    _no_warning(model)


def test_opting_out_keeps_the_contacts_and_is_reported():
    spec = _two_blocks()
    mjflex.add_flexure(spec, "hinge", "A", "B", pos=[0, 0, 0], K=K, exclude_contact=False)
    model = spec.compile()
    assert model.nexclude == 0
    with pytest.warns(UserWarning, match=rf"'A' and 'B' joined by flexure 'hinge' {TOUCHING} \(geoms 'ga' and 'gb'\)"):
        mjflex.Flexures(model)


def test_grounded_element_is_not_excluded_but_reported_when_touching():
    """The world holds floors: add_flexure leaves its contacts alone, and Flexures says when they touch at rest."""
    spec = _two_blocks()
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1], pos=[0, 0, -0.0095])
    mjflex.add_flexure(spec, "ground", "world", "B", pos=[0.02, 0, -0.01], K=K)
    model = spec.compile()
    assert model.nexclude == 0
    with pytest.warns(UserWarning, match=rf"'world' and 'B' joined by flexure 'ground' {TOUCHING}"):
        mjflex.Flexures(model)


FILE = """<mujoco><option gravity="0 0 0"/><worldbody>
  <body name="A" pos="-0.02 0 0"><freejoint/><geom name="ga" type="box" size="0.02 0.01 0.01" {ga}/>
    <site name="hinge/a" pos="0.02 0 0"/>{child}</body>
  <body name="B" pos="0.018 0 0"><freejoint/><geom name="gb" type="box" size="0.02 0.01 0.01"/>
    <site name="hinge/b" pos="-0.018 0 0"/></body>
</worldbody>{contact}
<custom><text name="mjflex:hinge" data='{{"mjflex": 1, "K": [0.3, 40, 0.25, 5e6, 3e5, 1.5e6]}}'/></custom></mujoco>"""


@pytest.mark.parametrize(
    "ga, child, contact, warns",
    [
        ("", "", "", True),  # as the README's first example, with overlapping geoms
        ("", "", '<contact><exclude body1="A" body2="B"/></contact>', False),  # what the README says to add
        ('contype="2" conaffinity="2"', "", "", False),  # incompatible collision bits (B: 1 and 1)
        ('contype="2" conaffinity="1"', "", "", True),  # compatible one way round is enough
        ('contype="2" conaffinity="2"', "", '<contact><pair geom1="ga" geom2="gb"/></contact>', True),
        ('contype="0" conaffinity="0"', '<body name="C" pos="0.02 0.005 0"><geom size="0.004"/></body>', "", True),
    ],
    ids=["overlap", "excluded", "incompatible", "compatible-one-way", "explicit-pair", "welded-child-touches"],
)
def test_file_written_model_touching_at_rest_warns(ga, child, contact, warns):
    model = mujoco.MjModel.from_xml_string(FILE.format(ga=ga, child=child, contact=contact))
    assert (_contacts(model) > 0) == warns  # the reference: MuJoCo's own collision detection at qpos0
    if warns:
        with pytest.warns(UserWarning, match=rf"flexure 'hinge' {TOUCHING}"):
            mjflex.Flexures(model)
    else:
        _no_warning(model)


def test_parent_and_child_are_filtered_by_mujoco_unless_the_filter_is_off():
    spec = _two_blocks(parent_child=True)
    mjflex.add_flexure(spec, "hinge", "A", "B", pos=[0, 0, 0], K=K, exclude_contact=False)
    model = spec.compile()
    _no_warning(model)  # MuJoCo never collides a body with its parent
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    with pytest.warns(UserWarning, match=TOUCHING):
        mjflex.Flexures(model)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    _no_warning(model)


def test_excluded_pair_moves_without_contact_forces(clean_callback):
    """The overlapping blocks joined by an element: no contact ever acts between them, the run stays bounded."""
    spec = _two_blocks()
    mjflex.add_flexure(spec, "hinge", "A", "B", pos=[0, 0, 0], K=K, B=1e-4 * K)
    spec.option.timestep = 2e-5
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qvel[11] = 20.0  # B spins about z
    with mjflex.Flexures(model):
        for _ in range(500):
            mujoco.mj_step(model, data)
            assert data.ncon == 0
    assert np.isfinite(data.qpos).all() and np.abs(data.qvel).max() < 100
