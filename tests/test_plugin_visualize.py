"""The engine plugin's visualize callback: every element drawn in MuJoCo's scene, coloured by its bending strain.

``mujoco.Renderer`` runs ``mjv_updateScene``, which calls the plugin's ``visualize`` once per
instance, as MuJoCo's viewer does. The reference colours are computed here independently: the
element's rotation about its z axis from the two sites' world poses (scipy, relative to their rest
pose at ``qpos0``), times its ``strain_per_radian``, over the documented full scale, through the
demo's colour map (:func:`mjflex.app.render.strain_colors`).
"""

import os

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from mjflex.app import render
from mjflex.app.arcade import STRAIN_SCALE
from mjflex.app.simulate import simulate
from mjflex.native import library
from tests.models import K_DEMO, two_body_spec
from tests.plugin_models import MODELS, as_records

ARCADE = os.path.join(MODELS, "arcade.xml")
PLUGIN = mujoco.mjtObj.mjOBJ_PLUGIN


@pytest.fixture(scope="module")
def deflected_arcade():
    """ARCADE 3 ms into the paper run: every element bent, some far (strains of 0-2 %)."""
    model = mujoco.MjModel.from_xml_path(ARCADE)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    for _ in range(300):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return model, data


def _plugin_geoms(renderer):
    scene = renderer.scene
    return [scene.geoms[i] for i in range(scene.ngeom) if scene.geoms[i].objtype == PLUGIN]


def _bending(model, data, sites):
    """|rotation about z| of frame b relative to frame a, relative to their relative pose at qpos0 (scipy)."""
    rest = mujoco.MjData(model)
    mujoco.mj_kinematics(model, rest)
    out = []
    for a, b in sites:
        R_ab = data.site_xmat[a].reshape(3, 3).T @ data.site_xmat[b].reshape(3, 3)
        R0 = rest.site_xmat[a].reshape(3, 3).T @ rest.site_xmat[b].reshape(3, 3)
        out.append(abs(Rotation.from_matrix(R0.T @ R_ab).as_rotvec()[2]))
    return np.array(out)


def test_every_element_is_drawn_as_its_site_coloured_by_its_strain(deflected_arcade):
    model, data = deflected_arcade
    flex = mjflex.Flexures(model)
    with mujoco.Renderer(model, 120, 160) as renderer:
        renderer.update_scene(data)  # the viewer's default option: site group 2 (ARCADE's flexure shapes) shown
        geoms = _plugin_geoms(renderer)
    assert len(geoms) == 48 and sorted(g.objid for g in geoms) == list(range(48))
    sites = flex.site_ids
    strain = _bending(model, data, sites) * np.array([r.strain_per_radian for r in flex.records])
    assert 0.002 < strain.max() < 0.05 and strain.min() < 0.2 * strain.max()  # the colours span the scale
    expected = render.strain_colors(strain / STRAIN_SCALE, 1.0)
    for e, g in enumerate(sorted(geoms, key=lambda g: g.objid)):  # instance i is element i (the file's order)
        a = sites[e, 0]
        assert g.type == model.site_type[a] and g.category == mujoco.mjtCatBit.mjCAT_DECOR
        np.testing.assert_allclose(g.size, 1.1 * model.site_size[a], rtol=1e-6)
        np.testing.assert_allclose(g.pos, data.site_xpos[a], rtol=0, atol=1e-6)
        np.testing.assert_allclose(g.mat.ravel(), data.site_xmat[a], rtol=0, atol=1e-6)
        np.testing.assert_allclose(g.rgba, expected[e], rtol=0, atol=2e-6)


def test_the_site_group_turns_the_drawing_off_and_the_scene_never_overflows(deflected_arcade):
    model, data = deflected_arcade
    option = mujoco.MjvOption()
    option.sitegroup[2] = 0  # ARCADE draws its flexures on sites of group 2
    with mujoco.Renderer(model, 120, 160) as renderer:
        renderer.update_scene(data, scene_option=option)
        assert _plugin_geoms(renderer) == []
    with mujoco.Renderer(model, 120, 160, max_geom=10) as small:
        small.update_scene(data)
        assert small.scene.ngeom == 10 and len(_plugin_geoms(small)) == 10  # drawn first, stopped at maxgeom


def test_without_strain_per_radian_the_rotation_is_shown_and_strain_scale_sets_the_full_scale():
    spec = two_body_spec(kind="plugin")
    mjflex.add_flexure(spec, "scaled", "A", "B", pos=[0.1, 0.02, 0.5], K=K_DEMO, strain_per_radian=0.2,
                       strain_scale=0.006)  # fmt: skip
    spec.site("link/a").group = spec.site("scaled/a").group = 0
    model = spec.compile()
    data = mujoco.MjData(model)
    turn = Rotation.from_rotvec([0.0, 0.0, 0.025]) * Rotation.from_quat(model.qpos0[10:14], scalar_first=True)
    data.qpos[10:14] = turn.as_quat(scalar_first=True)  # B turned by 0.025 rad about world z
    mujoco.mj_forward(model, data)
    flex = mjflex.Flexures(model)
    bending = _bending(model, data, flex.site_ids)
    assert 1e-3 < bending.min() and bending.max() < 0.03
    with mujoco.Renderer(model, 60, 80) as renderer:
        renderer.update_scene(data)
        rgba = {g.objid: g.rgba.copy() for g in _plugin_geoms(renderer)}
    scales = (library.constant("DEFAULT_ROTATION_SCALE"), 0.006 / 0.2)  # rotation over 0.1 rad; strain: its own
    for e, scale in enumerate(scales):
        assert 0.05 < bending[e] / scale < 0.95  # within the colour range: the scale shows
        np.testing.assert_allclose(rgba[e], render.strain_colors(bending[e] / scale, 1.0), atol=2e-6)
    with pytest.raises(ValueError, match="strain_scale must be"):
        mjflex.add_flexure(spec, "bad", "A", "B", pos=[0.1, 0.02, 0.5], K=K_DEMO, strain_scale=0.0)
    spec.plugins[1].config = {**dict(spec.plugins[1].config), "strain_scale": "-1"}
    with pytest.raises(ValueError, match=r"flexure 'scaled'.*strain_scale must be a finite number > 0"):
        spec.compile()


def test_a_rendered_frame_shows_the_elements_and_run_renderer_shows_its_own_colours(deflected_arcade):
    """Rendered: the plugin model differs from its text-record twin (same state) exactly by the plugin's drawing,
    which covers the flexures' sites; with their site group hidden both frames are identical. mjflex's RunRenderer
    colours the sites on the run's own scale and hides the plugin's drawing: both forms render the same."""
    model, data = deflected_arcade
    twin = as_records(mujoco.MjSpec.from_file(ARCADE)).compile()
    twin_data = mujoco.MjData(twin)
    twin_data.qpos[:] = data.qpos
    mujoco.mj_forward(twin, twin_data)
    camera = render.default_camera(model)
    frames = {}
    for group in (1, 0):
        option = mujoco.MjvOption()
        option.sitegroup[2] = group
        for name, m, d in (("plugin", model, data), ("record", twin, twin_data)):
            with mujoco.Renderer(m, 180, 320) as renderer:
                renderer.update_scene(d, camera=camera, scene_option=option)
                frames[name, group] = renderer.render().astype(int)
    drawn = np.abs(frames["plugin", 1] - frames["record", 1]).max(axis=2) > 30
    assert drawn.sum() > 150  # the elements' strain colours over the sites' static green
    assert np.array_equal(frames["plugin", 0], frames["record", 0])
    runs = []
    for m in (model, twin):
        flex = mjflex.Flexures(m)
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        with flex:
            run, _, _ = simulate(m, d, flex, 3e-4, sample_dt=1e-4, progress=False, keep_qpos=True)
        with render.RunRenderer(m, flex, run, width=160, height=96, look="fast") as renderer:
            runs.append(renderer.frame(len(run.time) - 1, label=False))
    assert np.array_equal(runs[0], runs[1])
