"""``python -m mjflex demo``: the paper's ARCADE run (sec. 6), its video, Fig. 4-like panels and plots.

Writes to its output folder: ``arcade.mp4`` (flexures coloured by bending strain, the time and
a colour bar drawn in), ``arcade_panels.png`` (six frames 0.5 ms apart with a colour bar),
``arcade_energy.png``, ``arcade_stroke.png`` and ``arcade_summary.json``: the run's summary
(:class:`mjflex.app.simulate.Summary`), the video's settings and where the command's wall time
went (``time_breakdown``, also printed at the end).

The video's default size follows the GL (:data:`SIZES`): a software GL (no GPU) draws on the
CPU, so it gets 960x540 and the fast look of :func:`mjflex.app.render.choose_look`; sizes and
``quality`` given by the user win.
"""

import json
import os
import sys
import time
from dataclasses import asdict, replace

import numpy as np

from . import figures, render
from .arcade import arcade_model
from .runs import exit_on_divergence, frame_picks, run_model
from .timing import Stopwatch

TITLE = "ARCADE-like guide: 105 rad/s spin + 5 m/s cylinder (paper sec. 6)"
CAPTION = (
    "Flexures (36 notch hinges, 12 leaf springs) coloured by their bending strain: green 0 %, yellow half-way, red at "
    "the run's largest, {top} %.\nRigid bodies: links grey, hubs orange, cylinder blue, base dark grey."
)
#: Times of the panels [s]: 0.5 ms apart, as the paper's Fig. 4.
PANEL_TIMES = tuple(0.5e-3 * i for i in range(6))
#: Default video size (width, height) by the kind of GL.
SIZES = {"hardware": (1280, 720), "software": (960, 540)}
FILES = ("arcade.mp4", "arcade_panels.png", "arcade_energy.png", "arcade_stroke.png", "arcade_summary.json")


def _even(x):
    return max(2, 2 * round(x / 2))


def video_size(width, height, gl: render.GLInfo):
    """(width, height): the user's where given (a missing one at 16:9), else :data:`SIZES` for the GL."""
    if width is None and height is None:
        return SIZES["software" if gl.software else "hardware"]
    width = _even(height * 16 / 9) if width is None else width
    return width, _even(width * 9 / 16) if height is None else height


def command_clock(process_started=None) -> Stopwatch:
    """A stopwatch for a command: from the process's start (then a first phase "start-up") if known, else from now."""
    clock = Stopwatch(process_started)
    if process_started is not None:
        clock.add("start-up", clock.elapsed(), time.process_time())
    return clock


def run_demo(out, *, duration=0.08, width=None, height=None, fps=30, slowdown=100.0, quality="auto", progress=True,
             clock=None) -> dict:  # fmt: skip
    """Run the demo into folder ``out`` (existing); returns what ``arcade_summary.json`` holds.

    ``clock`` (a :class:`~mjflex.app.timing.Stopwatch`, default: started now) gets the phases
    rendering set-up (the GL is probed before the run, the renderer made after it), model,
    provider, run, rendering, encoding, panels and plots.
    """
    clock = clock or Stopwatch()
    with clock.phase("rendering set-up"):
        gl = render.gl_info()  # before the run: a machine without a GL context says so at once
        width, height = video_size(width, height, gl)
    with clock.phase("model"):
        model, source = arcade_model()
    name = os.path.basename(source)
    with exit_on_divergence(name):
        summary, run, flex = run_model(model, name, duration=duration, keyframe="paper_run", every_step=True,
                                       progress=progress, clock=clock)  # fmt: skip
    with clock.phase("rendering set-up"):
        renderer = render.RunRenderer(model, flex, run, width=width, height=height, look=quality)
    with renderer:
        picks, slowdown = frame_picks(run, fps, slowdown)
        video = renderer.write_video(os.path.join(out, FILES[0]), picks, fps)
        clock.add("rendering", video.frames_s, video.cpu_s)  # this process's CPU, the GL's threads included
        clock.add("encoding", video.encode_wait_s, video.encoder_cpu_s)  # ffmpeg's CPU
        if progress:
            print(f"wrote {video.path} ({render.video_text(video, renderer, slowdown)})", file=sys.stderr)
        with clock.phase("panels"):
            _panels(os.path.join(out, FILES[1]), renderer, run)
    with clock.phase("plots"):
        figures.energy_plot(os.path.join(out, FILES[2]), run, TITLE)
        figures.stroke_plot(os.path.join(out, FILES[3]), run, TITLE)
    scale = renderer.scale
    report = asdict(summary)
    report["colours"] = {"quantity": scale.label, "unit": scale.unit, "max": scale.vmax * scale.factor}
    report["video"] = {
        "file": FILES[0], "frames": video.frames, "width": video.width, "height": video.height, "fps": fps,
        "slowdown": slowdown, "look": asdict(renderer.look), "gl": {**asdict(gl), "software": gl.software},
        "per_frame_ms": video.per_frame_ms(), "encoder": dict(render.ENCODER),
        "encoder_cpu_s": video.encoder_cpu_s,
    }  # fmt: skip
    report["time_breakdown"] = clock.breakdown()
    with open(os.path.join(out, FILES[4]), "w") as f:
        json.dump(report, f, indent=2)
    print(summary.text())
    per = video.per_frame_ms()
    print(f"video: {render.video_text(video, renderer, slowdown)}; per frame {per['total']:.1f} ms "
          f"({per['frames']:.1f} ms rendering, {per['encode_wait']:.1f} ms waiting for the encoder)")  # fmt: skip
    print(clock.text(report["time_breakdown"]))
    print(f"wrote {out}/{', '.join(FILES)}")
    return report


def _panels(path, renderer, run):
    """The frames at :data:`PANEL_TIMES`, cropped to what the frames show (the same box for all)."""
    t = run.array("time")
    picks = [int(np.argmin(np.abs(t - t[0] - dt))) for dt in PANEL_TIMES if dt <= t[-1] - t[0] + 1e-12]
    plain = replace(renderer.look, skybox=False, name="no background")  # black where nothing is drawn
    masks = [renderer.frame(k, label=False, look=plain) for k in picks]
    images = masks if not renderer.look.skybox else [renderer.frame(k, label=False) for k in picks]
    rows, cols = content_box(masks)
    scale = renderer.scale
    caption = CAPTION.format(top=scale.ticks_text(scale.vmax)) if scale.unit == "%" else None
    return figures.panel_figure(path, [image[rows, cols] for image in images], t[picks], TITLE, scale, caption)


def content_box(images, margin=0.04):
    """``(rows, cols)`` slices of the part of ``images`` (black where nothing is drawn) that any of them covers.

    ``margin``: added on every side, as a fraction of the image's larger side.
    """
    drawn = np.any(np.stack(images) > 0, axis=(0, 3))
    if not drawn.any():
        return slice(None), slice(None)
    pad = int(margin * max(drawn.shape))
    r, c = np.flatnonzero(drawn.any(axis=1)), np.flatnonzero(drawn.any(axis=0))
    return (slice(max(r[0] - pad, 0), r[-1] + pad + 1), slice(max(c[0] - pad, 0), c[-1] + pad + 1))
