"""Headless rendering of runs: flexures coloured by their bending strain, videos.

Rendering uses MuJoCo's offscreen renderer, whose OpenGL backend MuJoCo takes from the
``MUJOCO_GL`` environment variable. mjflex never sets it when imported. The rule: a backend
the user chose (``MUJOCO_GL`` set) is always used; when nothing was chosen and mjflex is asked
to render (:func:`make_renderer`: the command line's ``--video`` and ``demo``, :class:`RunRenderer`)
on Linux without a display (no ``DISPLAY`` / ``WAYLAND_DISPLAY``), it selects EGL
(``MUJOCO_GL=egl``, also inherited by child processes). Set ``MUJOCO_GL=osmesa`` where EGL is
not available (OSMesa: software, slower).

What a frame costs depends on the GL: a software one (Mesa's llvmpipe, what EGL gives on a
machine without a GPU) draws on the CPU, where multisampling, the skybox, shadows and
reflections cost most of a frame. :func:`gl_info` reads the ``GL_RENDERER`` string of a
context, and :func:`choose_look` leaves those out on a software GL unless asked for
(``quality="full"``); see :class:`Look`. Videos are encoded while frames are rendered, one at a
time, by the ffmpeg binary shipped in the ``imageio-ffmpeg`` package (no system ffmpeg needed),
with x264's fastest preset at a fixed quantizer (:data:`ENCODER`). Figures: :mod:`.figures`.
"""

import contextlib
import functools
import importlib
import os
import platform
import queue
import resource
import threading
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from ..mjcf.build import SHOWN_SITE_GROUPS
from .simulate import element_strain_per_radian

#: x264 settings of the videos: the fastest preset at quantizer 23. On ARCADE's frames at 960x540 it
#: needs a fraction of the encoder time of mediapy's default (preset medium, qp 28; scripts/demo.py
#: times both) with a higher fidelity, for larger files (scripts/encoder_quality.py records both:
#: docs/howto/render_headless.md).
ENCODER = {"preset": "ultrafast", "qp": 23}

#: Substrings of ``GL_RENDERER`` (lower case) of GL implementations that draw on the CPU.
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software rasterizer", "swiftshader", "lavapipe",
                      "microsoft basic render", "gdi generic", "apple software renderer")  # fmt: skip
QUALITIES = ("auto", "full", "fast")


def _ffmpeg():
    import imageio_ffmpeg  # late: the video stack, only when a video is written or read
    import mediapy  # late: the video stack, only when a video is written

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
    from mujoco.rendering.classic import gl_context  # late: imports OpenGL, after MUJOCO_GL is chosen

    importlib.reload(gl_context)  # mujoco.Renderer reads gl_context.GLContext when it is created
    return "egl"


def no_gl_context(backend, exc) -> RuntimeError:
    """The error for a GL context that could not be made, saying how to get one."""
    return RuntimeError(
        f"cannot create an offscreen OpenGL context with MUJOCO_GL={backend}: {exc}. On a machine without a "
        "display use MUJOCO_GL=egl (GPU or Mesa EGL) or MUJOCO_GL=osmesa (install libosmesa6), set before "
        "Python imports mujoco."
    )


@dataclass(frozen=True)
class GLInfo:
    """The OpenGL implementation MuJoCo renders with: ``MUJOCO_GL`` and the context's own strings.

    ``renderer`` is ``GL_RENDERER`` (e.g. ``"llvmpipe (LLVM 15.0.6, 256 bits)"``), None where it
    could not be read (then :attr:`software` is None: unknown, not guessed).
    """

    backend: str
    renderer: str | None = None
    vendor: str | None = None
    version: str | None = None

    @property
    def software(self) -> bool | None:
        if self.renderer is None:
            return None
        return any(name in self.renderer.lower() for name in SOFTWARE_RENDERERS)

    def text(self) -> str:
        kind = {True: "software", False: "hardware", None: "unknown"}[self.software]
        return f"{self.renderer or 'GL renderer not known'} ({kind}, MUJOCO_GL={self.backend})"


@functools.lru_cache(maxsize=4)
def _gl_query(backend):
    """``(strings, max_size)`` from one 16x16 context of the backend, made once per backend (each None where
    unreadable): ``GL_RENDERER``, ``GL_VENDOR``, ``GL_VERSION``, and the largest offscreen image side [pixels],
    the smaller of ``GL_MAX_RENDERBUFFER_SIZE`` (MuJoCo's offscreen buffer) and ``GL_MAX_VIEWPORT_DIMS``."""
    from mujoco.rendering.classic import gl_context  # late: imports OpenGL, after MUJOCO_GL is chosen

    if gl_context.GLContext is None:
        return None, None
    try:
        context = gl_context.GLContext(16, 16)
    except Exception as exc:  # the GL backends raise a variety of errors
        raise no_gl_context(backend, exc) from exc
    strings = size = None
    try:
        context.make_current()
        from OpenGL import GL  # after the backend's import, which chose PyOpenGL's platform

        with contextlib.suppress(Exception):  # a context PyOpenGL cannot query: the strings stay unknown
            strings = tuple(GL.glGetString(name).decode(errors="replace") for name in
                            (GL.GL_RENDERER, GL.GL_VENDOR, GL.GL_VERSION))  # fmt: skip
        with contextlib.suppress(Exception):
            dims = GL.glGetIntegerv(GL.GL_MAX_VIEWPORT_DIMS)
            size = int(min(int(GL.glGetIntegerv(GL.GL_MAX_RENDERBUFFER_SIZE)), *(int(d) for d in np.ravel(dims))))
        return strings, size
    finally:
        context.free()


def gl_info() -> GLInfo:
    """What ``GL_RENDERER`` a context of the selected backend reports (a 16x16 context, made once per backend).

    Raises RuntimeError (saying how to get a context) when none can be made.
    """
    backend = select_gl_backend()
    strings, _ = _gl_query(os.environ.get("MUJOCO_GL", ""))
    return GLInfo(backend, *strings) if strings else GLInfo(backend)


@dataclass(frozen=True)
class Look:
    """The parts of a frame that cost most in a software GL, each on or off.

    ``antialias``: the model's multisampling (``vis.quality.offsamples``, 4 by default) or none;
    ``skybox`` and ``haze`` go together (off: a black background). Shadows and reflections only
    show where the model has shadow-casting lights and reflective materials.
    """

    antialias: bool = True
    skybox: bool = True
    shadows: bool = True
    reflections: bool = True
    name: str = "full"

    def apply(self, scene):
        flags = mujoco.mjtRndFlag
        for flag, on in ((flags.mjRND_SKYBOX, self.skybox), (flags.mjRND_HAZE, self.skybox),
                         (flags.mjRND_SHADOW, self.shadows), (flags.mjRND_REFLECTION, self.reflections)):  # fmt: skip
            scene.flags[flag] = on


FULL = Look()
FAST = Look(antialias=False, skybox=False, shadows=False, reflections=False, name="fast")


def choose_look(quality, info: GLInfo) -> Look:
    """``quality``: ``"full"``, ``"fast"`` or ``"auto"`` (fast on a software GL, full otherwise or if unknown)."""
    if quality not in QUALITIES:
        raise ValueError(f"quality must be one of {QUALITIES}; got {quality!r}")
    return FAST if quality == "fast" or (quality == "auto" and info.software) else FULL


def make_renderer(model, width, height, *, antialias=True):
    """An offscreen ``mujoco.Renderer``; raises RuntimeError saying how to get a GL context.

    ``antialias=False`` creates it without multisampling (the model's ``offsamples`` is restored).
    """
    backend = select_gl_backend()
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    samples = model.vis.quality.offsamples
    if not antialias:
        model.vis.quality.offsamples = 0  # read when the context is made
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # the GL backends raise a variety of errors
        raise no_gl_context(backend, exc) from exc
    finally:
        model.vis.quality.offsamples = samples


def default_camera(model):
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = model.stat.center
    cam.distance = 1.7 * model.stat.extent
    cam.azimuth, cam.elevation = 35.0, -18.0
    return cam


def strain_colors(values, scale):
    """RGBA (n, 4): green (0) through yellow (``scale / 2``) to red (``>= scale``)."""
    x = np.clip(np.asarray(values, dtype=float) / scale, 0.0, 1.0)
    r = np.clip(2.0 * x, 0.0, 1.0)
    g = np.clip(2.0 * (1.0 - x), 0.0, 1.0)
    return np.stack([r, 0.85 * g, 0.1 * np.ones_like(x), np.ones_like(x)], -1)


@dataclass
class ColourScale:
    """What the flexures' colours show: ``values`` ``(samples, n)``, green at 0 to red at ``vmax``.

    ``label`` (``short`` in a video frame) and ``unit`` name the displayed quantity, ``values *
    factor`` in ``unit``.
    """

    values: np.ndarray
    vmax: float
    label: str
    short: str
    unit: str
    factor: float

    def ticks_text(self, value) -> str:
        return f"{value * self.factor:.3g}"


def colour_scale(flex, run, vmax=None) -> ColourScale:
    """Each element's bending at each sample of ``run``, as strain where every element states its strain.

    With ``strain_per_radian`` in every record: the peak bending strain at the element's
    thinnest section (``|rotation about z| * strain_per_radian``, shown in %); otherwise the
    rotation about the element's z axis of every element (shown in degrees), so that one
    colour means one value. ``vmax`` (in the values' own units: strain or rad) defaults to
    the largest value of the run.
    """
    bending = np.abs(run.array("bending"))
    per_rad = element_strain_per_radian(flex)
    if np.isfinite(per_rad).all():
        values, unit, factor = bending * per_rad, "%", 100.0
        label, short = "bending strain at the surface of the thinnest section", "bending strain"
    else:
        values, unit, factor = bending, "deg", 180 / np.pi
        label, short = "rotation about the element's z (bending) axis", "bending rotation"
    top = float(np.nanmax(values)) if values.size else 0.0
    return ColourScale(values, vmax or max(top, 1e-12), label, short, unit, factor)


#: Smallest video (width, height) [pixels]: the frames carry the time and a colour bar (:class:`_Overlay`).
MIN_VIDEO_SIZE = (64, 36)


class _Overlay:
    """The time (top left) and a colour bar of the scale (bottom left) drawn into video frames.

    The colour bar is drawn once; per frame only the small box of the time is drawn.
    """

    def __init__(self, width, height, scale: ColourScale | None):
        from PIL import Image, ImageDraw, ImageFont  # late: Pillow, only for captions and legends

        self.size = max(10, height // 28)
        try:
            self.font = ImageFont.load_default(size=self.size)
        except TypeError:  # Pillow < 10.1: fixed-size bitmap font
            self.font = ImageFont.load_default()
        self.box = (min(width, 12 * self.size), min(height, int(1.6 * self.size)))  # time: w, h
        self.legend = None
        if scale is None:
            return
        s = self.size
        w, h = min(width, 16 * s), min(height, int(3.4 * s))
        img = Image.new("RGB", (w, h), (24, 24, 28))
        bar = strain_colors(np.linspace(0.0, 1.0, w - s)[None, :].repeat(int(0.6 * s), 0), 1.0)[..., :3]
        img.paste(Image.fromarray((255 * bar).astype(np.uint8)), (s // 2, int(1.3 * s)))
        draw = ImageDraw.Draw(img)
        text = functools.partial(draw.text, fill=(235, 235, 235), font=self.font)
        text((s // 2, s // 6), f"{scale.short} [{scale.unit}]")
        ticks = int(2.0 * s)
        text((s // 2, ticks), "0")
        top = scale.ticks_text(scale.vmax)
        text((w - s // 2 - draw.textlength(top, font=self.font), ticks), top)
        self.legend = np.asarray(img)

    def draw(self, image, text):
        from PIL import Image, ImageDraw  # late: Pillow, only for captions and legends

        w, h = self.box
        patch = Image.fromarray(image[:h, :w])
        ImageDraw.Draw(patch).text((self.size // 2, self.size // 3), text, fill=(255, 255, 255), font=self.font)
        image[:h, :w] = np.asarray(patch)
        if self.legend is not None and self.legend.shape[0] < image.shape[0] // 2:
            lh, lw = self.legend.shape[:2]
            image[-lh:, :lw] = self.legend
        return image


@dataclass
class VideoStats:
    """A written video: frames, size, and where its wall time went [s].

    ``frames_s``: making the frames (the generator: scene, drawing, read-back, labels);
    ``encode_wait_s``: waiting for the encoder (its start, its full queue, its finishing);
    ``cpu_s``: CPU time of this process meanwhile (every thread: the GL's, the writer's);
    ``encoder_cpu_s``: CPU time of the ffmpeg process (it runs beside the frames, on other cores).
    """

    path: str
    frames: int
    width: int
    height: int
    fps: float
    frames_s: float
    encode_wait_s: float
    cpu_s: float
    encoder_cpu_s: float

    def per_frame_ms(self) -> dict:
        n = max(self.frames, 1)
        return {"frames": 1e3 * self.frames_s / n, "encode_wait": 1e3 * self.encode_wait_s / n,
                "cpu": 1e3 * self.cpu_s / n, "encoder_cpu": 1e3 * self.encoder_cpu_s / n,
                "total": 1e3 * (self.frames_s + self.encode_wait_s) / n}  # fmt: skip


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def write_video(path, frames, fps, *, queue_frames=2) -> VideoStats:
    """Encode ``frames`` (an iterable of ``(H, W, 3)`` uint8 images) as an H.264 MP4 (:data:`ENCODER`).

    Frames go to imageio-ffmpeg's ffmpeg as they come, through a queue of at most
    ``queue_frames`` frames that a thread writes to ffmpeg's input: a generator that renders
    them keeps a few images in memory whatever the length of the video, and goes on rendering
    while ffmpeg reads and encodes (on other cores).
    """
    clock = time.perf_counter
    frames = iter(frames)
    t0 = clock()
    first = next(frames, None)
    if first is None:
        raise ValueError(f"no frames to write to {path}")
    made, waited, count = clock() - t0, 0.0, 0
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    cpu, own = _children_cpu(), time.process_time()
    t0 = clock()
    with _ffmpeg().VideoWriter(path, shape=first.shape[:2], fps=fps, qp=ENCODER["qp"],
                               ffmpeg_args=["-preset", ENCODER["preset"]]) as writer:  # fmt: skip
        pending, failed = queue.Queue(maxsize=queue_frames), []

        def feed():
            while (image := pending.get()) is not None:
                if not failed:
                    try:
                        writer.add_image(image)
                    except BaseException as exc:  # raised in the caller's thread below
                        failed.append(exc)

        feeder = threading.Thread(target=feed, name="mjflex-video-writer", daemon=True)
        feeder.start()
        waited += clock() - t0
        image = first
        try:
            while image is not None and not failed:
                t0 = clock()
                pending.put(image)
                t1 = clock()
                count += 1
                image = next(frames, None)
                waited, made = waited + t1 - t0, made + clock() - t1
        finally:
            t0 = clock()
            pending.put(None)
            feeder.join()
        if failed:
            raise failed[0]
    waited += clock() - t0  # the writer and ffmpeg finishing the last frames
    height, width = first.shape[:2]
    own = time.process_time() - own
    return VideoStats(str(path), count, width, height, fps, made, waited, own, _children_cpu() - cpu)


def video_text(stats: VideoStats, renderer, slowdown) -> str:
    """``247 frames 960x540, 30 fps, 100x slow motion; fast look, llvmpipe (...) (software, ...)``."""
    return (f"{stats.frames} frames {stats.width}x{stats.height}, {stats.fps:g} fps, {slowdown:.4g}x slow motion; "
            f"{renderer.look.name} look, {renderer.gl.text()}")  # fmt: skip


def read_video(path):
    """Decode a video into an array ``(frames, height, width, 3)`` with imageio-ffmpeg's reader."""
    import imageio_ffmpeg  # late: the video stack, only when a video is written or read

    reader = imageio_ffmpeg.read_frames(path)
    width, height = next(reader)["size"]  # the first item: the video's metadata
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    return np.stack(frames) if frames else np.zeros((0, height, width, 3), np.uint8)


class RunRenderer:
    """Renders stored states of a run with each flexure's site coloured by its bending (:func:`colour_scale`).

    ``look``: a :class:`Look`, or a quality name of :func:`choose_look` (default ``"auto"``: fast
    on a software GL). ``width``/``height`` in pixels. Use as a context manager or :meth:`close`.
    """

    def __init__(self, model, flex, run, *, width=640, height=360, look="auto", strain_scale=None, camera=None):
        self.model, self.flex, self.run = model, flex, run
        self.gl = gl_info()
        self.look = choose_look(look, self.gl) if isinstance(look, str) else look
        self.renderer = make_renderer(model, width, height, antialias=self.look.antialias)
        self.data = mujoco.MjData(model)
        self.camera = camera or default_camera(model)
        self.option = mujoco.MjvOption()
        self.option.sitegroup[list(SHOWN_SITE_GROUPS)] = 1
        self.sites = flex.site_ids[:, 0]
        self.scale = colour_scale(flex, run, strain_scale)
        self.overlay = _Overlay(width, height, self.scale)

    @property
    def strain(self):
        """``(samples, n)`` values the colours show: ``scale.values`` of the run's :class:`ColourScale` ``scale``."""
        return self.scale.values

    def frame(self, k, label=True, look=None):
        """Sample ``k`` as an ``(H, W, 3)`` uint8 image; ``label``: time and colour bar drawn in.

        ``look``: a :class:`Look` for this frame only (its ``antialias`` is the renderer's).
        """
        self.data.qpos[:] = self.run.qpos[k]
        mujoco.mj_forward(self.model, self.data)
        self.model.site_rgba[self.sites] = strain_colors(self.scale.values[k], self.scale.vmax)
        self.renderer.update_scene(self.data, camera=self.camera, scene_option=self.option)
        scene = self.renderer.scene
        for geom in scene.geoms[: scene.ngeom]:  # the engine plugin's drawing (viewer colours, on a fixed scale)
            if geom.objtype == mujoco.mjtObj.mjOBJ_PLUGIN and geom.category == mujoco.mjtCatBit.mjCAT_DECOR:
                geom.type = mujoco.mjtGeom.mjGEOM_NONE  # blanked: the sites show the run's own scale
        (look or self.look).apply(scene)
        image = self.renderer.render()
        return self.overlay.draw(image, f"t = {self.run.time[k] * 1e3:.3f} ms") if label else image

    def write_video(self, path, picks, fps) -> VideoStats:
        """The samples ``picks`` as a video at ``fps``, labelled; see :func:`write_video`."""
        return write_video(path, (self.frame(k) for k in picks), fps)

    def close(self):
        self.renderer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: Image side [pixels] every OpenGL 3.0 implementation renders offscreen (the minimum the specification
#: allows for ``GL_MAX_RENDERBUFFER_SIZE``): sizes up to it are not queried.
GUARANTEED_IMAGE_SIZE = 1024


def max_image_size() -> int:
    """Largest width or height [pixels] of an offscreen image here (see :func:`_gl_query`).

    Queried once per process, from the same context as :func:`gl_info`; RuntimeError (saying how
    to get a GL context) where there is none or the limit cannot be read.
    """
    backend = select_gl_backend()
    _, size = _gl_query(os.environ.get("MUJOCO_GL", ""))
    if size is None:
        raise no_gl_context(backend, "GL_MAX_RENDERBUFFER_SIZE could not be read from the context")
    return size
