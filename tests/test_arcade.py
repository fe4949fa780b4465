"""The ARCADE showcase: counts, the committed model file, modes, energy and the rendered demo."""

import json
import os

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.app import cli
from mjflex.app.arcade import build_arcade_spec
from mjflex.app.modes import guide_report
from mjflex.app.render import read_video
from mjflex.app.simulate import configure, simulate
from tests.model_text import assert_xml_equivalent

MODELS = os.path.join(os.path.dirname(__file__), "..", "models")


def _joint_counts(model, flex):
    counts = {}
    for e in range(len(flex)):
        for body in flex.body_ids[e]:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(body))
            counts[name] = counts.get(name, 0) + 1
    return counts


@pytest.fixture(scope="module")
def arcade():
    model = mujoco.MjModel.from_xml_path(os.path.join(MODELS, "arcade.xml"))
    return model, mjflex.Flexures(model)


def test_counts_of_the_paper(arcade):
    model, flex = arcade
    assert model.nbody - 1 == 35
    assert all(model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE for b in range(1, model.nbody))
    assert sum(n.startswith("notch_") for n in flex.names) == 36
    assert sum(n.startswith("leaf_") for n in flex.names) == 12 and len(flex) == 48
    counts = _joint_counts(model, flex)
    assert counts.pop("base") == 12 and counts.pop("cylinder") == 6
    links = sorted(counts.values())
    assert len(links) == 33 and links.count(2) == 30 and links.count(6) == 3


def test_rigid_end_group_variant():
    model = mujoco.MjModel.from_xml_path(os.path.join(MODELS, "arcade_rigid.xml"))
    flex = mjflex.Flexures(model)
    assert model.nbody - 1 == 31 and len(flex) == 48
    counts = _joint_counts(model, flex)
    assert counts["ring_top"] == 6 and counts["ring_bottom"] == 6


@pytest.mark.parametrize("name, rigid", [("arcade.xml", False), ("arcade_rigid.xml", True)])
def test_committed_model_matches_the_generator(name, rigid):
    """The committed file is what scripts/build_arcade.py writes: every element, attribute and name, and every
    number to the round-off of the numerical libraries (tests/model_text.py says why; not byte for byte: a CPU
    without AVX-512 gives 36 of the numbers 1 ulp apart)."""
    with open(os.path.join(MODELS, name)) as f:
        committed = f.read()
    generated = build_arcade_spec(rigid_end_groups=rigid).to_xml()
    report = assert_xml_equivalent(generated, committed, hint="run scripts/build_arcade.py")
    assert report.numbers > 2700  # the plugin configurations' 924 numbers (K, B, strain, source) were compared too
    assert committed.count('<plugin plugin="mjflex.flexure">') == 1 and committed.count("<instance name=") == 48


@pytest.mark.parametrize("name", ["arcade.xml", "arcade_rigid.xml"])
def test_lowest_mode_is_the_axial_guide_motion(name):
    model = mujoco.MjModel.from_xml_path(os.path.join(MODELS, name))
    report = guide_report(model, mjflex.Flexures(model))
    assert report["n_rigid"] == 6  # free-floating: three translations, three rotations
    assert report["guide_is_axial"]
    assert report["separation"] > 2.5
    others = [m for m in report["modes"][7:] if m["is_axial_translation"]]
    assert all(m["frequency_hz"] > 2 * report["guide_frequency_hz"] for m in others)


def test_paper_run_conserves_energy_without_damping(arcade):
    """Default integrator (RK4) and step (1e-5 s): energy error below 1e-3 of the energy exchanged over 10 ms."""
    spec = mujoco.MjSpec.from_file(os.path.join(MODELS, "arcade.xml"))
    assert len(mjflex.edit_elements(spec, viscous=False)) == 48  # plugin elements: their switches are the model's
    model = spec.compile()
    flex = mjflex.Flexures(model)
    assert not flex.viscous.any() and set(flex.kinds) == {"plugin"}
    configure(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "paper_run"))
    run, _, _ = simulate(model, data, flex, 0.01, sample_dt=1e-4, progress=False)
    E = run.array("kinetic") + run.array("flexure_potential")
    exchanged = np.ptp(run.array("flexure_potential"))
    assert exchanged > 0.1  # joules: the run really loads the flexures
    assert np.abs(E - E[0]).max() <= 1e-3 * exchanged
    assert run.dissipated[-1] == 0.0


def test_demo_end_to_end_small(tmp_path):
    """The README's main command, CI-sized: video decodes, frames differ, figures written."""
    out = str(tmp_path)
    cli.main(["demo", "--out", out, "--duration", "0.003", "--width", "160", "--height", "96", "--slowdown", "300",
              "--quiet"])  # fmt: skip
    video = read_video(os.path.join(out, "arcade.mp4"))
    assert video.shape[0] >= 20 and video.shape[1:] == (96, 160, 3)
    assert np.abs(video[0].astype(int) - video[-1].astype(int)).mean() > 1.0
    for name in ("arcade_panels.png", "arcade_energy.png", "arcade_stroke.png"):
        assert os.path.getsize(os.path.join(out, name)) > 10_000
    with open(os.path.join(out, "arcade_summary.json")) as f:
        summary = json.load(f)
    assert summary["steps"] == 300 and abs(summary["energy_balance_relative"]) < 1e-3


def test_simulate_command_on_a_generic_model(tmp_path, capsys):
    cli.main(["simulate", os.path.join(MODELS, "two_body.xml"), "--duration", "0.05", "--video",
              str(tmp_path / "two.mp4"), "--width", "96", "--height", "64", "--slowdown", "2", "--quiet",
              "--json", str(tmp_path / "s.json")])  # fmt: skip
    text = capsys.readouterr().out
    assert "balance error" in text and "max flexure rotation" in text
    assert read_video(str(tmp_path / "two.mp4")).shape[0] >= 3


def test_cli_rejects_bad_arguments(tmp_path):
    with pytest.raises(SystemExit, match="not found"):
        cli.main(["simulate", str(tmp_path / "missing.xml")])
    with pytest.raises(SystemExit):
        cli.main(["simulate", os.path.join(MODELS, "arcade.xml"), "--duration", "-1"])
    with pytest.raises(SystemExit, match="no keyframe 'nope'"):
        cli.main(["simulate", os.path.join(MODELS, "arcade.xml"), "--keyframe", "nope", "--quiet"])
