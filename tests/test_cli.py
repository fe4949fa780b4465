"""The command line under bad input and divergence: messages before the run, non-zero exits, streamed video."""

import io
import json
import os
import platform
import subprocess
import sys
import tracemalloc

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.app import cli, runs
from mjflex.app.render import read_video
from mjflex.app.simulate import DivergenceError, Progress, simulate

MODELS = os.path.join(os.path.dirname(__file__), "..", "models")
TWO_BODY = os.path.join(MODELS, "two_body.xml")
NO_FLEXURES = """<mujoco model="plain"><worldbody><body name="a"><freejoint/>
<geom type="box" size="0.1 0.1 0.1"/></body></worldbody></mujoco>"""


def test_diverged_run_says_so_and_exits_non_zero(tmp_path, capsys):
    """Far beyond the stable step (the hinge's stiffest mode needs h < ~3e-4 s): MuJoCo's auto-reset is on in the
    file, and the run used to print a summary of a reset state and exit 0."""
    summary = tmp_path / "s.json"
    with pytest.raises(SystemExit) as exit_:
        cli.main(["simulate", TWO_BODY, "--timestep", "1e-3", "--duration", "0.05", "--json", str(summary)])
    out, err = capsys.readouterr()
    assert exit_.value.code == runs.EXIT_DIVERGED
    assert "diverged in the step from t = " in err and "flexure 'hinge'" in err and "No summary" in err
    assert "energy" not in out and not summary.exists()


def test_a_timestep_above_the_advised_limit_is_warned_with_the_advice(capsys):
    """--timestep above the stable step of the model's integrator at the initial state: a warning before the run gives
    mjflex.step_advice's limit and recommendation there; a stable --timestep runs without one."""
    with pytest.raises(SystemExit):
        cli.main(["simulate", TWO_BODY, "--timestep", "1e-3", "--duration", "0.01", "--quiet"])
    err = capsys.readouterr().err
    model = mujoco.MjModel.from_xml_path(TWO_BODY)
    advice = mjflex.step_advice(model, keyframe=0)  # the run starts from the file's keyframe (its pose: qpos0)
    assert (f"--timestep 0.001 s is above the largest stable step of RK4 at the initial state, {advice.limit:.3g} s "
            f"(mjflex.step_advice; set by the {advice.frequency:.4g} Hz mode)") in err  # fmt: skip
    assert f"Take --timestep {advice.recommended:.2g}" in err and err.index("above the largest") < err.index("diverged")
    cli.main(["simulate", TWO_BODY, "--timestep", f"{advice.recommended:.2g}", "--duration", "0.01", "--quiet"])
    assert "above the largest stable step" not in capsys.readouterr().err


def test_divergence_found_by_mujoco_names_the_quantity_and_restores_auto_reset():
    """With the element switched off the flexure cannot report; MuJoCo's own bad-qvel warning stops the run."""
    model = mujoco.MjModel.from_xml_path(TWO_BODY)
    flex = mjflex.Flexures(model)
    flex.set_enabled("hinge", False)
    data = mujoco.MjData(model)
    data.qvel[0] = 2e10  # beyond MuJoCo's mjMAXVAL (1e10)
    flags = model.opt.disableflags
    # the one step convention of mjflex.runtime.divergence: the step that starts at t, its index counted from 0
    with pytest.raises(
        DivergenceError, match=r"step index 0, counting from 0\) of its 10 steps: .*huge qvel\[0\]"
    ) as error:
        simulate(model, data, flex, 10 * model.opt.timestep, progress=False)
    assert error.value.step == 1 and error.value.time == 0.0 and len(error.value.run.time) == 1
    assert model.opt.disableflags == flags  # auto-reset as the model had it


def _main_error(args, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(args)
    err = capsys.readouterr().err + str(exit_.value.code)
    assert exit_.value.code != 0 and "Traceback" not in err
    assert "simulating" not in err  # found before the run
    return err


@pytest.mark.parametrize("value", ["0", "nan", "-1e-5", "inf", "x"])
def test_bad_timestep_is_a_message(value, capsys):
    err = _main_error(["simulate", TWO_BODY, "--timestep", value], capsys)
    assert "argument --timestep" in err


def test_duration_shorter_than_a_step_is_a_message(capsys):
    err = _main_error(["simulate", TWO_BODY, "--duration", "1e-6"], capsys)
    assert "duration 1e-06 s is shorter than one time step (2e-05 s)" in err


def test_model_without_flexures_is_a_message(tmp_path, capsys):
    path = tmp_path / "plain.xml"
    path.write_text(NO_FLEXURES)
    err = _main_error(["simulate", str(path)], capsys)
    assert "plain.xml has no mjflex elements" in err


@pytest.mark.parametrize("option, name", [("--json", "s.json"), ("--video", "v.mp4")])
def test_output_in_a_missing_folder_is_a_message(option, name, tmp_path, capsys):
    err = _main_error(["simulate", TWO_BODY, option, str(tmp_path / "missing" / name)], capsys)
    assert f"{option} " in err and "does not exist" in err


def test_video_without_a_known_suffix_is_a_message(tmp_path, capsys):
    err = _main_error(["simulate", TWO_BODY, "--video", str(tmp_path / "v.mp5")], capsys)
    assert "must end in one of .mp4" in err


def _video_peak_memory(path, frames, trace=True):
    """Peak Python memory [B] of a simulate command that writes a 320x240 video of ``frames`` frames (+ 1)."""
    if trace:
        tracemalloc.start()
    try:
        cli.main(["simulate", TWO_BODY, "--duration", f"{frames / 1500:.6g}", "--timestep", "1e-4", "--slowdown",
                  "50", "--video", str(path), "--width", "320", "--height", "240", "--quiet"])  # fmt: skip
        return tracemalloc.get_traced_memory()[1] if trace else None
    finally:
        tracemalloc.stop()


def test_video_frames_are_streamed_to_the_encoder(tmp_path, capsys):
    """A video of 50 frames needs no more memory than one of 10: the encoder gets one frame at a time (holding them
    all took 21 GB for 1 s of ARCADE at 3000 frames per simulated second)."""
    frame_bytes = 320 * 240 * 3
    _video_peak_memory(
        tmp_path / "warm.mp4", 2, trace=False
    )  # one-off allocations (compilation, caches) out of the way
    short = _video_peak_memory(tmp_path / "short.mp4", 10)
    long = _video_peak_memory(tmp_path / "long.mp4", 50)
    assert "wrote" not in capsys.readouterr().err  # --quiet
    video = read_video(str(tmp_path / "long.mp4"))
    assert video.shape[0] == round(50 / 1500 / 1e-4 / 7) + 1 and video.shape[1:] == (240, 320, 3)
    assert np.abs(video[0].astype(int) - video[-1].astype(int)).mean() > 0.5  # the frames show the motion
    assert long - short < 4 * frame_bytes, f"40 more frames took {(long - short) / frame_bytes:.1f} frames more"


def test_progress_is_not_redrawn_in_a_log(capsys):
    """stderr is not a terminal here: a few plain lines, no carriage-return redraws."""
    cli.main(["simulate", TWO_BODY, "--duration", "0.05"])
    captured = capsys.readouterr()
    assert "\r" not in captured.err
    lines = captured.err.splitlines()
    assert lines[0].startswith("simulating") and lines[-1].startswith("progress: 100.0%") and len(lines) <= 3
    assert "wall time of the run" in captured.out and "wall time of the whole command" in captured.out


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_progress_estimate_leaves_out_the_first_step():
    """The first step carries one-off costs (3 s here); the estimate uses the rate of the steps after it."""
    clock, stream = _Clock(), io.StringIO()
    stream.isatty = lambda: True
    bar = Progress(1000, stream, clock=clock, interval=0.0)
    clock.now = 3.0
    bar.update(1)
    assert "estimating" in stream.getvalue()
    for done in range(2, 21):
        clock.now += 0.01
        bar.update(done)
    assert bar.eta(20, clock.now) == pytest.approx(980 * 0.01)
    assert stream.getvalue().rsplit("\r", 1)[-1].endswith("~9.8 s left")


def test_simulate_command_summary_json(tmp_path, capsys):
    path = tmp_path / "s.json"
    cli.main(["simulate", TWO_BODY, "--duration", "0.01", "--quiet", "--json", str(path)])
    summary = json.loads(path.read_text())
    assert summary["steps"] == 500 and summary["duration"] == pytest.approx(0.01, rel=1e-12)
    assert 0 < summary["wall_time"] < 60 and summary["mujoco_warnings"] == {}


_RENDER_IN_A_FRESH_PROCESS = """
import os, platform
import mjflex, mujoco
from mjflex.app.render import make_renderer
assert "MUJOCO_GL" not in os.environ, "import mjflex chose a GL backend"
if platform.system() == "Linux":
    model = mujoco.MjModel.from_xml_path({model!r})
    renderer = make_renderer(model, 64, 48)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    renderer.update_scene(data)
    image = renderer.render()
    renderer.close()
    print(os.environ["MUJOCO_GL"], image.shape, int(image.max()))
"""


def test_gl_backend_is_chosen_only_when_rendering():
    """Headless, nothing chosen: importing mjflex leaves MUJOCO_GL alone; rendering on Linux selects EGL."""
    hidden = ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")
    env = {k: v for k, v in os.environ.items() if k not in hidden}
    done = subprocess.run([sys.executable, "-c", _RENDER_IN_A_FRESH_PROCESS.format(model=TWO_BODY)], env=env,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    if platform.system() == "Linux":
        assert done.stdout.startswith("egl (48, 64, 3)") and int(done.stdout.split()[-1]) > 0


def test_an_unnamed_keyframe_is_the_default_start_and_is_chosen_by_its_index(tmp_path, capsys):
    """A model whose only keyframe has no name starts from it (it once failed with "no keyframe '0'"), by default or
    by ``--keyframe 0``; an index past the last keyframe is a message."""
    spec = mujoco.MjSpec.from_file(TWO_BODY)
    for key in list(spec.keys):
        spec.delete(key)
    model = spec.compile()
    spec.add_key(qpos=model.qpos0.copy(), qvel=np.r_[np.zeros(6), 0.5, np.zeros(5)])  # B spinning about x
    path = tmp_path / "unnamed_key.xml"
    path.write_text(spec.to_xml())
    for extra in ([], ["--keyframe", "0"]):
        out = tmp_path / "s.json"
        cli.main(["simulate", str(path), "--duration", "0.001", "--quiet", "--json", str(out), *extra])
        summary = json.loads(out.read_text())
        assert summary["steps"] == 50 and summary["energy_start"] == pytest.approx(0.01215, rel=1e-9)  # its spin
    err = _main_error(["simulate", str(path), "--keyframe", "1"], capsys)
    assert "no keyframe '1'; the model has [None]" in err
