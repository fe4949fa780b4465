"""Headless rendering of runs: flexures coloured by strain, videos, panels and plots.

Rendering uses MuJoCo's offscreen renderer, whose OpenGL backend MuJoCo takes from the
``MUJOCO_GL`` environment variable. mjflex never sets it when imported. The rule: a backend
the user chose (``MUJOCO_GL`` set) is always used; when nothing was chosen and mjflex is asked
to render (:func:`make_renderer`: the command line's ``--video`` and ``demo``, :class:`RunRenderer`)
on Linux without a display (no ``DISPLAY`` / ``WAYLAND_DISPLAY``), it selects EGL
(``MUJOCO_GL=egl``, also inherited by child processes). Set ``MUJOCO_GL=osmesa`` where EGL is
not available (OSMesa: software, slower). Videos are encoded while frames are rendered, one at a
time, by the ffmpeg binary shipped in the ``imageio-ffmpeg`` package (no system ffmpeg needed).
Figures are drawn with matplotlib's object-oriented API, so the user's pyplot backend is left as
it is.
"""

import functools
import importlib
import itertools
import os
import platform

import mujoco
import numpy as np

from ..mj.build import SHOWN_SITE_GROUPS
from .simulate import element_strain_per_radian


def _ffmpeg():
    import imageio_ffmpeg
    import mediapy

    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
    return mediapy


def select_gl_backend() -> str:
    """Apply the backend rule of this module before creating a renderer; returns ``MUJOCO_GL``.

    Headless Linux with no backend chosen: ``MUJOCO_GL=egl`` is set and MuJoCo's context
    selection (made when mujoco was imported) is redone with it.
    """
    chosen = os.environ.get("MUJOCO_GL")
    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if chosen or platform.system() != "Linux" or not headless:
        return chosen or "(unset: MuJoCo's default)"
    os.environ["MUJOCO_GL"] = "egl"
    from mujoco.rendering.classic import gl_context

    importlib.reload(gl_context)  # mujoco.Renderer reads gl_context.GLContext when it is created
    return "egl"


def no_gl_context(backend, exc) -> RuntimeError:
    """The error for a GL context that could not be made, saying how to get one."""
    return RuntimeError(
        f"cannot create an offscreen OpenGL context with MUJOCO_GL={backend}: {exc}. On a machine without a "
        "display use MUJOCO_GL=egl (GPU or Mesa EGL) or MUJOCO_GL=osmesa (install libosmesa6), set before "
        "Python imports mujoco."
    )


def make_renderer(model, width, height):
    """An offscreen ``mujoco.Renderer``; raises RuntimeError saying how to get a GL context."""
    backend = select_gl_backend()
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # the GL backends raise a variety of errors
        raise no_gl_context(backend, exc) from exc


def default_camera(model):
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = model.stat.center
    cam.distance = 1.7 * model.stat.extent
    cam.azimuth, cam.elevation = 35.0, -18.0
    return cam


def strain_colors(values, scale):
    """RGBA (n, 4): green (0) through yellow to red (``>= scale``)."""
    x = np.clip(np.asarray(values, dtype=float) / scale, 0.0, 1.0)
    r = np.clip(2.0 * x, 0.0, 1.0)
    g = np.clip(2.0 * (1.0 - x), 0.0, 1.0)
    return np.stack([r, 0.85 * g, 0.1 * np.ones_like(x), np.ones_like(x)], -1)


def _label(image, text):
    from PIL import Image, ImageDraw, ImageFont

    img = Image.fromarray(image)
    size = max(10, image.shape[0] // 28)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: fixed-size bitmap font
        font = ImageFont.load_default()
    ImageDraw.Draw(img).text((size // 2, size // 3), text, fill=(255, 255, 255), font=font)
    return np.asarray(img)


class RunRenderer:
    """Renders stored states of a run with each flexure's site coloured by its strain."""

    def __init__(self, model, flex, run, *, width=640, height=360, strain_scale=None, camera=None):
        self.model, self.flex, self.run = model, flex, run
        self.renderer = make_renderer(model, width, height)
        self.data = mujoco.MjData(model)
        self.camera = camera or default_camera(model)
        self.option = mujoco.MjvOption()
        for g in SHOWN_SITE_GROUPS:
            self.option.sitegroup[g] = 1
        self.sites = flex.site_ids[:, 0]
        per_rad = element_strain_per_radian(flex)
        bending = np.abs(run.array("bending"))
        self.strain = np.where(np.isfinite(per_rad), bending * per_rad, bending)  # rotation where no strain known
        self.scale = strain_scale or max(float(np.nanmax(self.strain)), 1e-12)

    def frame(self, k, label=True):
        self.data.qpos[:] = self.run.qpos[k]
        mujoco.mj_forward(self.model, self.data)
        self.model.site_rgba[self.sites] = strain_colors(self.strain[k], self.scale)
        self.renderer.update_scene(self.data, camera=self.camera, scene_option=self.option)
        image = self.renderer.render()
        return _label(image, f"t = {self.run.time[k] * 1e3:7.3f} ms") if label else image

    def close(self):
        self.renderer.close()


def write_video(path, frames, fps) -> int:
    """Encode ``frames`` (an iterable of ``(H, W, 3)`` uint8 images) as an H.264 MP4; returns the count.

    Frames are passed to imageio-ffmpeg's ffmpeg one at a time as they come, so a generator
    that renders them keeps one image in memory, whatever the length of the video.
    """
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise ValueError(f"no frames to write to {path}")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    count = 0
    with _ffmpeg().VideoWriter(path, shape=first.shape[:2], fps=fps) as writer:
        for image in itertools.chain((first,), frames):
            writer.add_image(image)
            count += 1
    return count


def read_video(path):
    """Decode a video into an array ``(frames, height, width, 3)`` with imageio-ffmpeg's reader."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(path)
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    return np.stack(frames) if frames else np.zeros((0, height, width, 3), np.uint8)


def _figure(**kwargs):
    """A matplotlib figure that needs no pyplot backend (saved with ``fig.savefig``)."""
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def panel_figure(path, images, times, title):
    """A 2x3 figure of rendered frames, as the paper's Fig. 4."""
    fig = _figure(figsize=(12, 5.2))
    axes = fig.subplots(2, 3)
    for ax, image, t in zip(axes.ravel(), images, times, strict=False):
        ax.imshow(image)
        ax.set_title(f"t = {t * 1e3:.1f} ms", fontsize=10)
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def energy_plot(path, run, title):
    """Kinetic, elastic and dissipated energy, and the balance error, against time."""
    t = run.array("time") * 1e3
    kinetic, elastic = run.array("kinetic"), run.array("flexure_potential") + run.array("mujoco_potential")
    dissipated = run.array("dissipated")
    total = kinetic + elastic
    fig = _figure(figsize=(8, 6))
    a, b = fig.subplots(2, 1, sharex=True)
    a.plot(t, elastic, label="flexure potential energy")
    a.plot(t, dissipated, label="dissipated by flexure damping")
    a.plot(t, kinetic - kinetic[0], label="kinetic energy - initial")
    a.set_ylabel("energy [J]")
    a.legend(loc="upper left", fontsize=8)
    a.set_title(title)
    b.plot(t, total + dissipated - total[0], color="k")
    b.set_ylabel("balance error [J]\n(E + dissipated - E0)")
    b.set_xlabel("time [ms]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def stroke_plot(path, run, title):
    """Axial position of the cylinder relative to the base against time."""
    fig = _figure(figsize=(8, 3.5))
    ax = fig.subplots()
    ax.plot(run.array("time") * 1e3, run.array("stroke") * 1e3)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("cylinder stroke [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


#: Image side [pixels] every OpenGL 3.0 implementation renders offscreen (the minimum the specification
#: allows for ``GL_MAX_RENDERBUFFER_SIZE``): sizes up to it are not queried.
GUARANTEED_IMAGE_SIZE = 1024


@functools.cache
def max_image_size() -> int:
    """Largest width or height [pixels] of an offscreen image here: the GL's ``GL_MAX_RENDERBUFFER_SIZE``
    (MuJoCo's offscreen buffer is a renderbuffer) and ``GL_MAX_VIEWPORT_DIMS``, whichever is smaller.

    Queried once per process from a 1x1 context of the backend :func:`select_gl_backend` picks;
    RuntimeError (saying how to get a GL context) where there is none.
    """
    backend = select_gl_backend()
    from mujoco.rendering.classic import gl_context

    context = None
    try:
        context = gl_context.GLContext(1, 1)
        context.make_current()
        from OpenGL import GL

        dims = GL.glGetIntegerv(GL.GL_MAX_VIEWPORT_DIMS)
        return int(min(int(GL.glGetIntegerv(GL.GL_MAX_RENDERBUFFER_SIZE)), *(int(d) for d in np.ravel(dims))))
    except Exception as exc:  # the GL backends raise a variety of errors
        raise no_gl_context(backend, exc) from exc
    finally:
        if context is not None:
            context.free()


def image_size_problem(width, height, what=("width", "height")) -> str | None:
    """Why an offscreen image of ``width`` x ``height`` pixels cannot be rendered here, or None.

    Checked before a run (the command line's ``--video`` and ``demo``): MuJoCo's offscreen buffer
    (``model.vis.global_.offwidth`` / ``offheight``, which :func:`make_renderer` raises to the
    size asked for) can be no larger than the GL's limit, :func:`max_image_size`.
    """
    if max(width, height) <= GUARANTEED_IMAGE_SIZE:
        return None  # no GL context needed to know (creating one costs ~0.3 s)
    limit = max_image_size()
    for name, size in zip(what, (width, height), strict=True):
        if size > limit:
            return (
                f"{name} {size} is larger than the {limit} pixels the OpenGL here renders offscreen "
                f"(GL_MAX_RENDERBUFFER_SIZE with MUJOCO_GL={os.environ.get('MUJOCO_GL', 'unset')}); use at most {limit}"
            )
    return None
