"""A run of a model with mjflex elements, as the command line and the demo make it: load, simulate, render.

* :func:`load_model` reads a model file, with the elements' method or damping changed in the
  spec first (the only way for plugin elements, whose parameters are the model's);
* :func:`run_model` checks everything, simulates (:func:`mjflex.app.simulate.simulate`) and
  renders a video; :func:`frame_picks` chooses the samples a video shows;
* :func:`exit_on_divergence` turns a diverged run into a message and exit status
  :data:`EXIT_DIVERGED` (the command line's and the demo's contract).

Problems are ``SystemExit`` with a message (``error: ...``): these functions are what the
commands do, callable from Python with the same checks.
"""

import os
import sys
import time
from contextlib import contextmanager

import mujoco
import numpy as np

from ..mjcf.elements import edit_elements
from ..runtime.flexures import Flexures
from ..runtime.tables import ModelError
from . import render
from .simulate import DivergenceError, configure, simulate, step_count, summarize, timestep_warning
from .timing import Stopwatch

#: Exit status of a run that diverged (1: bad input, 2: bad command line).
EXIT_DIVERGED = 3


def check_video_size(width, height):
    """Raise SystemExit (before the run) if a ``width`` x ``height`` video cannot be rendered here.

    MuJoCo's offscreen buffer (``model.vis.global_.offwidth`` / ``offheight``, which
    :func:`mjflex.app.render.make_renderer` raises to the size asked for) can be no larger than the
    GL's limit, :func:`mjflex.app.render.max_image_size`.
    """
    small_w, small_h = render.MIN_VIDEO_SIZE
    if width < small_w or height < small_h:
        raise SystemExit(f"error: --width and --height must be at least {small_w} x {small_h} pixels for a video (its "
                         f"frames carry the time and a colour bar); got {width} x {height}")  # fmt: skip
    if max(width, height) <= render.GUARANTEED_IMAGE_SIZE:
        return  # no GL context needed to know (creating one costs ~0.3 s)
    try:
        limit = render.max_image_size()
    except RuntimeError as exc:
        raise SystemExit(f"error: no video can be rendered here: {exc}") from None
    for name, size in (("--width", width), ("--height", height)):
        if size > limit:
            raise SystemExit(
                f"error: {name} {size} is larger than the {limit} pixels the OpenGL here renders offscreen "
                f"(GL_MAX_RENDERBUFFER_SIZE with MUJOCO_GL={os.environ.get('MUJOCO_GL', 'unset')}); use at most {limit}"
            )


def load_model(path, method=None, damping=True):
    """The model of ``path``; ``method`` / ``damping=False`` are written into every element before it compiles
    (the only way for plugin elements, whose parameters are the model's; text records get the same)."""
    if not os.path.exists(path):
        raise SystemExit(f"error: model file {path!r} not found")
    try:
        if method is None and damping:
            return mujoco.MjModel.from_xml_path(path)
        spec = mujoco.MjSpec.from_file(path)
        try:
            edit_elements(spec, method=method, viscous=None if damping else False)
        except ValueError as exc:
            option = "--method" if method is not None else "--no-damping"
            raise SystemExit(f"error: {os.path.basename(path)}: {option}: {exc}") from None
        return spec.compile()
    except ValueError as exc:
        raise SystemExit(f"error: MuJoCo cannot load {path!r}: {exc}") from None


def initial_state(model, keyframe):
    """A data at ``keyframe`` (a name, or an index for an unnamed one; None: the first keyframe, else qpos0), after
    ``mj_forward``, and the keyframe's label (None at qpos0)."""
    data = mujoco.MjData(model)
    if keyframe is None and model.nkey > 0:
        keyframe = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, 0) or "0"
    if keyframe is not None:
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
        if key < 0 and keyframe.isdigit() and int(keyframe) < model.nkey:  # an unnamed keyframe, by its index
            key = int(keyframe)
        if key < 0:
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, i) for i in range(model.nkey)]
            raise SystemExit(f"error: no keyframe {keyframe!r}; the model has {names} (an unnamed one: its index)")
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    return data, keyframe


def frame_picks(run, fps, slowdown):
    """Indices of the stored samples to show at ``fps`` with time slowed down ``slowdown`` times, and the
    slow-motion factor they give.

    Samples are taken a whole number of steps apart: when they are not denser than the frames,
    every sample is one frame (the factor then follows from the sample interval); otherwise
    the sample nearest each frame time is shown.
    """
    t = run.array("time")
    frame_dt = 1.0 / (fps * slowdown)
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else frame_dt
    if spacing > 0.5 * frame_dt:
        return np.arange(len(t)), 1.0 / (fps * spacing)
    wanted = np.arange(t[0], t[-1] + 0.5 * frame_dt, frame_dt)
    return np.unique(np.clip(np.round(np.interp(wanted, t, np.arange(len(t)))).astype(int), 0, len(t) - 1)), slowdown


def run_model(model, name, *, duration, method=None, integrator=None, timestep=None, keyframe=None, damping=True,
              video=None, width=640, height=360, fps=30, slowdown=100.0, every_step=False, progress=True,
              quality="auto", clock=None):  # fmt: skip
    """Simulate ``model`` and optionally render a video; returns ``(summary, run, flex)``.

    Everything is checked before the run (SystemExit with a message). Samples are taken every
    video frame (or every step with ``every_step``); states are kept only for the video, which is
    rendered and encoded frame by frame after the run (``quality``: of
    :func:`mjflex.app.render.choose_look`). A divergence raises
    :class:`mjflex.app.simulate.DivergenceError`. ``clock``: a :class:`~mjflex.app.timing.Stopwatch`
    given the phases "model" (reading the elements too), "provider" (installing the callback for text
    records) and "run". ``method`` / ``damping=False``: switched at run time for text records; a
    plugin element must hold them already (SystemExit otherwise: :func:`load_model` writes them into
    the spec, which is what the command line does, so it passes neither).
    """
    clock, started, cpu = clock or Stopwatch(), time.perf_counter(), time.process_time()
    try:
        configure(model, integrator=integrator, timestep=timestep)
        step_count(duration, model.opt.timestep)
        flex = Flexures(model)
    except (ModelError, ValueError) as exc:
        raise SystemExit(f"error: {name}: {exc}") from None
    if video:
        check_video_size(width, height)
    if not len(flex):
        raise SystemExit(
            f"error: {name} has no mjflex elements (mjflex.flexure plugin instances, or sites E/a, E/b and a text "
            "record mjflex:E; see mjflex.mjcf.schema or docs/reference/mjcf_schema.md), so there is nothing to report; "
            "check the warnings above for misspelt records"
        )
    _switch(flex, name, method, damping)
    data, key = initial_state(model, keyframe)
    warning = timestep_warning(model, flex, data, name) if timestep is not None else None
    if warning:
        print(warning, file=sys.stderr)
    clock.add("model", time.perf_counter() - started, time.process_time() - cpu)
    with clock.phase("provider"):
        flex.install()  # the callback for text records (nothing for plugin elements)
        flex.uninstall()
    # without a video, samples only for the energy series (the maxima are tracked every step)
    sample_dt = None if every_step else 1.0 / (fps * slowdown) if video else duration / 2000
    if progress:
        start = f"keyframe {key!r}" if key else "qpos0 at rest"
        print(f"simulating {name} for {duration * 1e3:g} ms from {start}", file=sys.stderr)
    with clock.phase("run"):
        run, wall, steps = simulate(
            model, data, flex, duration, sample_dt=sample_dt, progress=progress, keep_qpos=bool(video) or every_step
        )
        summary = summarize(name, model, flex, run, wall, steps)
    if video:
        with render.RunRenderer(model, flex, run, width=width, height=height, look=quality) as renderer:
            picks, slowdown = frame_picks(run, fps, slowdown)
            written = renderer.write_video(video, picks, fps)
        if progress:
            print(f"wrote {video} ({render.video_text(written, renderer, slowdown)})", file=sys.stderr)
    return summary, run, flex


def _switch(flex, name, method, damping):
    """Every element's method and damping: text records switch here; plugin elements must hold them already."""
    for i, element in enumerate(flex.names):
        if flex.kinds[i] == "record":
            if method is not None:
                flex.set_method(element, method)
            if not damping:
                flex.set_viscous(element, False)
        elif (method is not None and flex.methods[i] != method) or (not damping and flex.viscous[i]):
            raise SystemExit(
                f"error: {name}: flexure {element!r} is an mjflex.flexure plugin instance, whose method and damping "
                "are part of the model: compile it with them (mjflex.edit_elements on its MjSpec; the command line's "
                "--method and --no-damping do this)"
            )


@contextmanager
def exit_on_divergence(name):
    """A diverged run: its message on stderr, nothing written, exit status ``EXIT_DIVERGED``."""
    try:
        yield
    except DivergenceError as exc:
        print(f"error: {name}: {exc} No summary, JSON or video written.", file=sys.stderr)
        raise SystemExit(EXIT_DIVERGED) from None
