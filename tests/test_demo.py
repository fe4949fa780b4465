"""``python -m mjflex demo``: its time breakdown, the GL's look, the colours' meaning, the panels and the plots.

Real rendering (the machine's GL), real videos decoded again, real matplotlib figures checked
through their objects.
"""

import json
import os
import subprocess
import sys
import time

import mujoco
import numpy as np
import pytest
from matplotlib.collections import QuadMesh

import mjflex
from mjflex.app import arcade, cli, demo, figures, render
from mjflex.app.render import FAST, FULL, GLInfo, choose_look, colour_scale, read_video, strain_colors
from mjflex.app.simulate import element_strain_per_radian, simulate
from mjflex.app.timing import Stopwatch, process_start

from .models import hinge_chain_spec, set_initial_motion

ROOT = os.path.join(os.path.dirname(__file__), "..")
PHASES = ["rendering set-up", "model", "provider", "run", "rendering", "encoding", "panels", "plots"]


def _demo(out, *extra):
    cli.main(["demo", "--out", str(out), "--duration", "0.003", "--slowdown", "300", "--quiet", *extra])
    with open(os.path.join(out, "arcade_summary.json")) as f:
        return json.load(f)


@pytest.fixture(scope="module")
def small_demo(tmp_path_factory):
    """The demo CI-sized: 3 ms (300 steps), 28 frames at 192 px wide (the height follows at 16:9)."""
    out = tmp_path_factory.mktemp("demo")
    return out, _demo(out, "--width", "192")


def test_time_breakdown_covers_the_command(small_demo):
    """Every phase is reported, and together they are the command's wall time: the gaps between them (JSON,
    bookkeeping) are small. Called in-process, the start-up before the command is not part of it."""
    _, summary = small_demo
    b = summary["time_breakdown"]
    assert list(b["phases_s"]) == PHASES and all(s >= 0 for s in b["phases_s"].values())
    assert sum(b["phases_s"].values()) + b["unaccounted_s"] == pytest.approx(b["total_s"], rel=1e-9)
    # a generous bound (a loaded machine may pause between phases), far below a forgotten phase (the plots or the
    # panels, 0.3-2 s here)
    assert abs(b["unaccounted_s"]) < 0.05 * b["total_s"] + 0.05, b
    per = summary["video"]["per_frame_ms"]
    assert per["total"] == pytest.approx(per["frames"] + per["encode_wait"])
    frames = summary["video"]["frames"]
    assert b["phases_s"]["rendering"] == pytest.approx(1e-3 * per["frames"] * frames)


def test_video_decodes_with_the_frames_size_and_legend(small_demo):
    """3 ms at 300x slow motion and 30 fps: a frame every 1/9000 s, 28 frames (both ends); 192 px wide at 16:9."""
    out, summary = small_demo
    video = read_video(os.path.join(out, "arcade.mp4"))
    assert video.shape == (28, 108, 192, 3)
    assert summary["video"]["frames"] == 28 and (summary["video"]["width"], summary["video"]["height"]) == (192, 108)
    assert np.abs(video[0].astype(int) - video[-1].astype(int)).mean() > 0.5  # the frames show the motion
    # the colour bar at the bottom left: green at its left end, red at its right end (after H.264)
    scale = render.ColourScale(np.zeros((1, 1)), 0.02, "", "bending strain", "%", 100.0)
    overlay = render._Overlay(192, 108, scale)
    legend = overlay.legend.astype(int)
    row = int(1.3 * overlay.size) + 3  # the middle of the bar
    green, red = overlay.size // 2 + 3, overlay.size // 2 + legend.shape[1] - overlay.size - 4
    assert (
        legend[row, green, 1] > 200 > 50 > legend[row, green, 0]
        and legend[row, red, 0] > 200 > 50 > legend[row, red, 1]
    )
    frame = video[0, -legend.shape[0] :, : legend.shape[1]].astype(int)
    assert frame[row, green, 1] > 150 > 100 > frame[row, green, 0], frame[row, green]
    assert frame[row, red, 0] > 150 > 100 > frame[row, red, 1], frame[row, red]


def test_run_numbers_and_colours_are_stated(small_demo):
    """The summary keeps the run's numbers; the colours' quantity, unit and top are the run's bending strain."""
    _, summary = small_demo
    assert summary["steps"] == 300 and abs(summary["energy_balance_relative"]) < 1e-3
    colours = summary["colours"]
    assert colours["unit"] == "%" and "bending strain" in colours["quantity"]
    # peak over every step (the summary) and over the stored samples (every step in the demo) agree
    assert colours["max"] == pytest.approx(100 * summary["max_strain"], rel=1e-12)


def test_options_the_user_gives_win(tmp_path):
    """--quality full on a software GL keeps multisampling, skybox, shadows and reflections; --height alone gives
    the width at 16:9."""
    summary = _demo(tmp_path, "--quality", "full", "--height", "72", "--duration", "0.001")
    video = summary["video"]
    assert video["look"] == {"antialias": True, "skybox": True, "shadows": True, "reflections": True, "name": "full"}
    assert (video["width"], video["height"]) == (128, 72)
    assert read_video(os.path.join(tmp_path, "arcade.mp4")).shape[1:] == (72, 128, 3)


def test_default_size_and_look_follow_the_gl():
    info = render.gl_info()
    assert info.renderer and isinstance(info.software, bool)  # this machine's GL answered
    expected = demo.SIZES["software" if info.software else "hardware"]
    assert demo.video_size(None, None, info) == expected
    assert choose_look("auto", info) == (FAST if info.software else FULL)


@pytest.mark.parametrize(
    "renderer, software",
    [("llvmpipe (LLVM 15.0.6, 256 bits)", True), ("softpipe", True), ("SwiftShader Device (Subzero)", True),
     ("Mesa Intel(R) UHD Graphics 630 (CFL GT2)", False), ("NVIDIA GeForce RTX 4090/PCIe/SSE2", False),
     ("Apple M2", False), (None, None)],
)  # fmt: skip
def test_software_gl_is_read_from_the_renderer_string(renderer, software):
    info = GLInfo("egl", renderer)
    assert info.software is software
    assert choose_look("auto", info) == (FAST if software else FULL)  # unknown: the full look, not a guess
    assert choose_look("full", info) == FULL and choose_look("fast", info) == FAST
    assert demo.video_size(None, None, info) == ((960, 540) if software else (1280, 720))
    assert demo.video_size(640, None, info) == (640, 360) and demo.video_size(None, 100, info) == (178, 100)


def test_unknown_quality_is_refused():
    with pytest.raises(ValueError, match="quality must be one of"):
        choose_look("best", GLInfo("egl"))


def _chain_run(strains):
    """A chain of len(strains) + 1 links whose element i states strain_per_radian strains[i] (None: none)."""
    spec = hinge_chain_spec(n=len(strains) + 1)
    for i, strain in enumerate(strains, start=1):
        if strain is not None:
            text = next(t for t in spec.texts if t.name == f"mjflex:flex{i}")
            record = json.loads(text.data)
            record["strain_per_radian"] = strain
            text.data = json.dumps(record)
    model = spec.compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    set_initial_motion(model, data, seed=3, scale=3.0)
    run, _, _ = simulate(model, data, flex, 0.02, progress=False)
    return model, flex, run


def test_colours_show_strain_only_where_every_element_states_it():
    """One colour means one value in one unit: strain [%] where every element has strain_per_radian, else the
    bending rotation of every element [deg] (never strain for some and radians for others)."""
    _, flex, run = _chain_run([0.2, 0.05])
    bending = np.abs(np.array([b for b in run.bending]))  # (samples, n) rotation about each element's z [rad]
    scale = colour_scale(flex, run)
    np.testing.assert_allclose(scale.values, bending * [0.2, 0.05], rtol=1e-12)
    assert (scale.unit, scale.factor) == ("%", 100.0) and scale.vmax == pytest.approx((bending * [0.2, 0.05]).max())
    _, flex, run = _chain_run([0.2, None])
    assert np.isnan(element_strain_per_radian(flex)[1])
    scale = colour_scale(flex, run)
    np.testing.assert_allclose(scale.values, np.abs(np.array(run.bending)), rtol=1e-12)
    assert scale.unit == "deg" and scale.factor == pytest.approx(180 / np.pi) and "rotation" in scale.label


def test_frames_colour_each_flexure_by_its_strain():
    """The site of each element gets strain_colors(value / vmax): green at 0, red at the run's largest."""
    model, flex, run = _chain_run([0.2, 0.05])
    with render.RunRenderer(model, flex, run, width=64, height=48) as renderer:
        k = int(np.argmax(renderer.strain.max(axis=1)))
        image = renderer.frame(k)
        assert image.shape == (48, 64, 3)
        rgba = model.site_rgba[flex.site_ids[:, 0]]
    np.testing.assert_allclose(rgba, strain_colors(renderer.strain[k], renderer.scale.vmax), atol=1e-6)
    assert rgba[np.argmax(renderer.strain[k]), :3] == pytest.approx([1.0, 0.0, 0.1], abs=1e-6)  # the largest: red
    np.testing.assert_allclose(strain_colors([0.0, 0.5, 1.0, 3.0], 1.0)[:, :3],
                               [[0, 0.85, 0.1], [1, 0.85, 0.1], [1, 0, 0.1], [1, 0, 0.1]])  # fmt: skip


def _overlaps(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_panels_have_readable_titles_and_a_colour_bar_with_units(tmp_path):
    """Six real frames: each titled with its time, no title over another panel's image, and a colour bar whose
    range is the strain's, in %, drawn with the frames' colours."""
    model, _ = arcade.arcade_model()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "paper_run"))
    run, _, _ = simulate(model, data, flex, 0.0026, sample_dt=1e-4, progress=False)
    with render.RunRenderer(model, flex, run, width=192, height=108) as renderer:
        fig = demo._panels(str(tmp_path / "panels.png"), renderer, run)
        scale = renderer.scale
    assert os.path.getsize(tmp_path / "panels.png") > 10_000
    images = [ax for ax in fig.axes if ax.images]
    assert [ax.get_title() for ax in images] == [f"t = {0.5 * i:.1f} ms" for i in range(6)]
    bars = [ax for ax in fig.axes if not ax.images and ax.get_visible()]
    assert len(bars) == 1 and bars[0].get_ylabel() == "bending strain [%]"
    assert bars[0].get_ylim() == pytest.approx((0.0, 100 * scale.vmax))
    (solids,) = (c for c in bars[0].collections if isinstance(c, QuadMesh))  # the bar's colours
    cmap = solids.cmap
    np.testing.assert_allclose(
        cmap(np.linspace(0, 1, 5))[:, :3], strain_colors(np.linspace(0, 1, 5), 1)[:, :3], atol=2 / 255
    )  # 256 entries: one step of the steepest channel (1.7 per unit)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer_ = FigureCanvasAgg(fig).get_renderer()
    for ax in images:
        title = ax.title.get_window_extent(renderer_)
        for other in images:
            assert other is ax or not _overlaps(title, other.get_window_extent(renderer_)), ax.get_title()
    caption = fig._supxlabel.get_text()
    assert f"red at the run's largest, {100 * scale.vmax:.3g} %" in caption and "links grey" in caption


def test_energy_and_stroke_plots_state_their_units(tmp_path):
    """What is drawn is the quantity times the factor the axis label states (µJ for a balance error of 1e-6 J)."""
    *_, run = _chain_run([0.2, 0.05])
    run.stroke = list(1e-3 * np.sin(np.linspace(0, 3, len(run.time))))  # m
    fig = figures.energy_plot(str(tmp_path / "e.png"), run, "chain")
    top, bottom = fig.axes
    kinetic = np.array(run.kinetic)
    total = kinetic + np.array(run.flexure_potential) + np.array(run.mujoco_potential)
    balance = total + np.array(run.dissipated) - total[0]
    factor = {"[J]": 1.0, "[mJ]": 1e3, "[µJ]": 1e6, "[nJ]": 1e9}
    unit = next(u for u in factor if u in bottom.get_ylabel())
    np.testing.assert_allclose(bottom.lines[0].get_ydata(), factor[unit] * balance, rtol=1e-12)
    unit = next(u for u in factor if u in top.get_ylabel())
    np.testing.assert_allclose(top.lines[2].get_ydata(), factor[unit] * (kinetic - kinetic[0]), rtol=1e-12)
    assert top.get_xlabel() == "" and bottom.get_xlabel() == "time [ms]"
    np.testing.assert_allclose(bottom.lines[0].get_xdata(), 1e3 * np.array(run.time))
    (ax,) = figures.stroke_plot(str(tmp_path / "s.png"), run, "chain").axes
    assert "[mm]" in ax.get_ylabel() and ax.get_xlabel() == "time [ms]"
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 1e3 * np.array(run.stroke))


def test_energy_unit_is_chosen_by_size():
    assert figures._energy_unit([0.7, -0.2]) == (1.0, "J")
    assert figures._energy_unit([2e-5, -1.4e-5]) == (1e6, "µJ")
    assert figures._energy_unit([3e-4]) == (1e3, "mJ")


def test_stopwatch_adds_phases_and_reports_the_rest():
    clock = Stopwatch(start=time.perf_counter() - 1.0)
    clock.add("a", 0.25)
    with clock.phase("b"):
        pass
    clock.add("a", 0.25)
    b = clock.breakdown()
    assert list(b["phases_s"]) == ["a", "b"] and b["phases_s"]["a"] == 0.5
    assert b["total_s"] >= 1.0 and b["unaccounted_s"] == pytest.approx(b["total_s"] - 0.5 - b["phases_s"]["b"])
    assert clock.text(b).startswith("where the time went: a 0.50 s")


_AGE = "import time; t = time.perf_counter(); import mjflex.app.timing as T; print(t - T.process_start())"


@pytest.mark.skipif(process_start() is None, reason="the process start is read from /proc (Linux)")
def test_process_start_is_before_the_first_line_of_python():
    """In a fresh interpreter, the process started before Python ran its first line (to the kernel's 10 ms ticks),
    and not long before: a wrong field of /proc/self/stat gives seconds since boot, or nothing."""
    done = subprocess.run([sys.executable, "-c", _AGE], capture_output=True, text=True, check=True, timeout=60)
    assert -0.02 < float(done.stdout) < 30


def test_command_line_times_its_start_up_and_exits_cleanly(tmp_path):
    """``python -m mjflex demo`` as a user runs it: status 0, every file complete, and a breakdown that starts at
    the process's start (so it includes the imports) and ends before the process does."""
    env = {k: v for k, v in os.environ.items() if k != "MJFLEX_RECORD"}
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "mjflex", "demo", "--out", str(tmp_path), "--duration", "0.001",
                           "--width", "96", "--height", "64"], capture_output=True, text=True, timeout=600, env=env,
                          cwd=ROOT)  # fmt: skip
    outside = time.perf_counter() - t0
    assert done.returncode == 0, done.stderr
    assert "where the time went: start-up" in done.stdout and done.stdout.rstrip().endswith("arcade_summary.json")
    with open(tmp_path / "arcade_summary.json") as f:
        b = json.load(f)["time_breakdown"]
    assert list(b["phases_s"]) == ["start-up", *PHASES] and b["phases_s"]["start-up"] > 0
    assert b["total_s"] <= outside + 0.02  # the process's start is after the test's clock started (10 ms ticks)
    assert read_video(str(tmp_path / "arcade.mp4")).shape == (4, 64, 96, 3)  # 1 ms at 3000 frames per second
