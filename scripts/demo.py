"""The first impression of ``python -m mjflex demo``, measured: where its time goes, and what a frame costs.

Usage::

    python scripts/demo.py [--repeat 3] [--frames 40] [--json out/demo.json]
    MJFLEX_RECORD=1 python scripts/demo.py      # also docs/results/demo.json (docs/howto/render_headless.md)

1. The command as a user runs it: ``python -m mjflex demo --quiet`` in fresh processes, with
   its defaults and with the look and size it had before (``--quality full --width 1280
   --height 720``), interleaved ``--repeat`` times. Per run: the wall time seen from outside
   (start to exit), the child's CPU time, and the command's own breakdown from
   ``arcade_summary.json`` (start-up, model, provider, run, rendering, encoding, panels, plots).
2. One frame of ARCADE by size and look (:class:`mjflex.app.render.Look`): drawing
   (``mjr_render`` then ``glFinish``, since a software GL draws when asked to finish) and reading
   back (``mjr_readPixels``), wall and CPU time of this process (the GL's threads included),
   medians of interleaved repeats over ``--frames`` states of the paper's run; then the
   encoder's CPU time per frame, with the demo's settings and with mediapy's defaults.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict

import mujoco
import numpy as np
from _bench import write_json

import mjflex
from mjflex.app import render
from mjflex.app.cli import arcade_model
from mjflex.app.simulate import simulate

COMMANDS = {"default": [], "before: full look, 1280x720": ["--quality", "full", "--width", "1280", "--height", "720"]}
SIZES = [(1280, 720), (960, 540), (640, 360)]
LOOKS = {
    "full": render.FULL,
    "full, no multisampling": render.Look(antialias=False, name="no multisampling"),
    "full, no skybox": render.Look(skybox=False, name="no skybox"),
    "fast": render.FAST,
}
ENCODERS = {"demo (ultrafast, qp 23)": dict(render.ENCODER), "mediapy default (medium, qp 28)": None}


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_command(extra, folder):
    """One ``python -m mjflex demo``: outside wall and CPU time, and its arcade_summary.json."""
    cpu, t0 = _children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "mjflex", "demo", "--out", folder, "--quiet", *extra], check=True,
                   stdout=subprocess.DEVNULL)  # fmt: skip
    wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu
    with open(os.path.join(folder, "arcade_summary.json")) as f:
        summary = json.load(f)
    return {"wall_s": wall, "cpu_s": cpu, "summary": summary}


def _stats(values):
    v = np.asarray(values, float)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def command_runs(repeat):
    runs = {name: [] for name in COMMANDS}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat):
            for name, extra in COMMANDS.items():
                runs[name].append(run_command(extra, os.path.join(tmp, f"{i}")))
                r = runs[name][-1]
                print(f"{name:<32} {r['wall_s']:6.2f} s wall, {r['cpu_s']:6.2f} s CPU", flush=True)
    out = {}
    for name, rs in runs.items():
        phases = rs[0]["summary"]["time_breakdown"]["phases_s"]
        video = rs[-1]["summary"]["video"]
        out[name] = {
            "options": COMMANDS[name], "runs": len(rs), "wall_s": _stats([r["wall_s"] for r in rs]),
            "cpu_s": _stats([r["cpu_s"] for r in rs]),
            "total_s": _stats([r["summary"]["time_breakdown"]["total_s"] for r in rs]),
            "phases_s": {p: _stats([r["summary"]["time_breakdown"]["phases_s"][p] for r in rs]) for p in phases},
            "frame_ms": _stats([r["summary"]["video"]["per_frame_ms"]["total"] for r in rs]),
            "frames": video["frames"], "width": video["width"], "height": video["height"], "look": video["look"],
            "gl": video["gl"], "run_wall_s": _stats([r["summary"]["wall_time"] for r in rs]),
        }  # fmt: skip
    return out


def _states(count):
    model, _ = arcade_model()
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "paper_run"))
    run, _, _ = simulate(model, data, flex, count / 3000, sample_dt=1 / 3000, progress=False)  # the video's frames
    return model, flex, run


def _draw_and_read(renderer, run, look):
    """Per frame [ms]: (draw wall, read-back wall, CPU of both)."""
    from OpenGL import GL

    r = renderer.renderer
    image = np.empty((r.height, r.width, 3), np.uint8)
    draw = read = cpu = 0.0
    for k in range(len(run.time)):
        renderer.data.qpos[:] = run.qpos[k]
        mujoco.mj_forward(renderer.model, renderer.data)
        r.update_scene(renderer.data, camera=renderer.camera, scene_option=renderer.option)
        look.apply(r.scene)
        r._gl_context.make_current()
        c0, t0 = time.process_time(), time.perf_counter()
        mujoco.mjr_render(r._rect, r.scene, r._mjr_context)
        GL.glFinish()
        t1 = time.perf_counter()
        mujoco.mjr_readPixels(image, None, r._rect, r._mjr_context)
        t2, c1 = time.perf_counter(), time.process_time()
        draw, read, cpu = draw + t1 - t0, read + t2 - t1, cpu + c1 - c0
    n = 1e-3 * len(run.time)
    return draw / n, read / n, cpu / n


def _encoder_cpu_ms(frames, settings):
    """CPU time [ms] of ffmpeg per frame encoding ``frames`` with ``settings`` (None: mediapy's defaults)."""
    media = render._ffmpeg()
    shape = frames[0].shape[:2]
    kwargs = {} if settings is None else {"qp": settings["qp"], "ffmpeg_args": ["-preset", settings["preset"]]}
    with tempfile.TemporaryDirectory() as tmp:
        cpu = _children_cpu()
        with media.VideoWriter(os.path.join(tmp, "v.mp4"), shape=shape, fps=30, **kwargs) as writer:
            for image in frames:
                writer.add_image(image)
        cpu = _children_cpu() - cpu
        size = os.path.getsize(os.path.join(tmp, "v.mp4"))
    return 1e3 * cpu / len(frames), size / len(frames)


def frame_costs(count, repeat):
    model, flex, run = _states(count)
    configs = [(w, h, name) for (w, h) in SIZES for name in LOOKS]
    renderers = {}
    for w, h, name in configs:
        renderers[(w, h, name)] = render.RunRenderer(model, flex, run, width=w, height=h, look=LOOKS[name])
    times = {c: [] for c in configs}
    for _ in range(repeat):
        for c in configs:
            times[c].append(_draw_and_read(renderers[c], run, LOOKS[c[2]]))
    rows = []
    for (w, h, name), t in times.items():
        t = np.array(t)
        rows.append({"width": w, "height": h, "look": name, "draw_ms": float(np.median(t[:, 0])),
                     "read_ms": float(np.median(t[:, 1])), "cpu_ms": float(np.median(t[:, 2]))})  # fmt: skip
        print(f"{w}x{h} {name:<24} draw {rows[-1]['draw_ms']:6.2f} ms, read-back {rows[-1]['read_ms']:5.2f} ms, "
              f"CPU {rows[-1]['cpu_ms']:6.2f} ms", flush=True)  # fmt: skip
    encoders = []
    for w, h in SIZES:
        images = [renderers[(w, h, "fast")].frame(k) for k in range(len(run.time))]
        for name, settings in ENCODERS.items():
            cpu, size = _encoder_cpu_ms(images, settings)
            encoders.append({"width": w, "height": h, "encoder": name, "cpu_ms": cpu, "bytes_per_frame": size})
            print(f"{w}x{h} encoder {name:<32} CPU {cpu:6.2f} ms a frame, {size / 1e3:5.1f} kB a frame", flush=True)
    for r in renderers.values():
        r.close()
    gl = render.gl_info()
    return {"frames": len(run.time), "repeats": repeat, "rows": rows, "encoders": encoders,
            "gl": {**asdict(gl), "software": gl.software}}  # fmt: skip


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each command, interleaved (default 3)")
    ap.add_argument("--frames", type=int, default=40, help="ARCADE states per frame measurement (default 40)")
    ap.add_argument("--frame-repeat", type=int, default=5, help="interleaved rounds of the frame measurement")
    ap.add_argument("--json", default=os.path.join("out", "demo.json"))
    args = ap.parse_args()
    commands = command_runs(args.repeat)
    frames = frame_costs(args.frames, args.frame_repeat)
    write_json(args.json, {"commands": commands, "frame_costs": frames})


if __name__ == "__main__":
    main()
