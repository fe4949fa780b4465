"""Headless rendering of runs: flexures coloured by strain, videos, panels and plots.

Rendering uses MuJoCo's offscreen renderer. On Linux without a display mjflex selects EGL
(``MUJOCO_GL=egl``) when it is imported before mujoco; set ``MUJOCO_GL=osmesa`` where EGL is
not available (OSMesa: software, slower). Videos are encoded with the ffmpeg binary shipped in
the ``imageio-ffmpeg`` package (no system ffmpeg needed).
"""

import os

import mujoco
import numpy as np

FLEXURE_SITE_GROUPS = (3, 4)  # mjflex draws flexures in these site groups (see mjflex.mj.build, app.arcade)


def _ffmpeg():
    import imageio_ffmpeg
    import mediapy

    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
    return mediapy


def make_renderer(model, width, height):
    """An offscreen ``mujoco.Renderer``; raises RuntimeError saying how to get a GL context."""
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # the GL backends raise a variety of errors
        backend = os.environ.get("MUJOCO_GL", "(unset: glfw)")
        raise RuntimeError(
            f"cannot create an offscreen OpenGL context with MUJOCO_GL={backend}: {exc}. On a machine without a "
            "display use MUJOCO_GL=egl (GPU or Mesa EGL) or MUJOCO_GL=osmesa (install libosmesa6), set before "
            "Python imports mujoco."
        ) from exc


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
        for g in FLEXURE_SITE_GROUPS:
            self.option.sitegroup[g] = 1
        self.sites = flex.site_ids[:, 0]
        per_rad = np.array([r.strain_per_radian if r.strain_per_radian is not None else np.nan for r in flex.records])
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


def write_video(path, frames, fps):
    """Encode ``frames`` (list of HxWx3 uint8) as an H.264 MP4 with imageio-ffmpeg's ffmpeg."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    _ffmpeg().write_video(path, frames, fps=fps)


def read_video(path):
    """Decode a video into an array ``(frames, height, width, 3)`` with imageio-ffmpeg's reader."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(path)
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    return np.stack(frames) if frames else np.zeros((0, height, width, 3), np.uint8)


def panel_figure(path, images, times, title):
    """A 2x3 figure of rendered frames, as the paper's Fig. 4."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(12, 5.2))
    for ax, image, t in zip(axes.ravel(), images, times, strict=False):
        ax.imshow(image)
        ax.set_title(f"t = {t * 1e3:.1f} ms", fontsize=10)
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def energy_plot(path, run, title):
    """Kinetic, elastic and dissipated energy, and the balance error, against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = run.array("time") * 1e3
    kinetic, elastic = run.array("kinetic"), run.array("flexure_potential") + run.array("mujoco_potential")
    dissipated = run.array("dissipated")
    total = kinetic + elastic
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
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
    plt.close(fig)


def stroke_plot(path, run, title):
    """Axial position of the cylinder relative to the base against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(run.array("time") * 1e3, run.array("stroke") * 1e3)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("cylinder stroke [mm]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
