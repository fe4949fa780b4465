"""Screenshot of MuJoCo's own viewer running an mjflex plugin model, after some simulated time.

Usage::

    python scripts/viewer_screenshot.py [--model models/arcade.xml] [--keyframe paper_run] [--time 0.02]
                                        [--out docs/viewer_arcade.png] [--width 960 --height 540]

It imports ``mujoco`` only (never ``mjflex``: ``import mujoco`` registers the engine plugin
``mjflex.flexure`` through its entry point), opens ``mujoco.viewer.launch_passive`` on the model,
resets it to the keyframe (ARCADE's ``paper_run``: 105 rad/s of spin and 5 m/s of the cylinder),
steps ``--time`` seconds of simulated time and grabs the viewer's window from the X display
(Pillow's ``ImageGrab``). Without a display (``DISPLAY`` unset) it starts a virtual one with
``Xvfb`` (Debian: ``apt-get install xvfb``) and stops it at the end.

It prints, and writes beside the image as JSON, what says the model held together: the largest
distance between the two sites ``E/a``, ``E/b`` of any element after the run [m] (they coincide
at rest and stay within the elements' small deflections; with the elements' forces missing,
e.g. the text-record form of the model in a program without mjflex, the bodies fly apart at
metres per second: 10-25 cm in ARCADE's 20 ms) and the frame's contents. Exit status 1 when the
guide came apart (``--max-separation``, default 1 cm; ARCADE's elements deflect about 1 mm in the
paper run) or the window stayed blank.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def start_display(width, height):
    """``(display, process)`` of a new Xvfb server, or ``(DISPLAY, None)`` when one is set already."""
    if os.environ.get("DISPLAY"):
        return os.environ["DISPLAY"], None
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        raise SystemExit("error: no X display (DISPLAY is unset) and no Xvfb to start one: apt-get install xvfb")
    for number in range(91, 120):
        if os.path.exists(f"/tmp/.X11-unix/X{number}") or os.path.exists(f"/tmp/.X{number}-lock"):
            continue
        process = subprocess.Popen([xvfb, f":{number}", "-screen", "0", f"{width}x{height}x24", "-nolisten", "tcp"],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
        for _ in range(100):
            if os.path.exists(f"/tmp/.X11-unix/X{number}"):
                return f":{number}", process
            if process.poll() is not None:
                break
            time.sleep(0.05)
        process.kill()
    raise SystemExit("error: Xvfb did not start")


def element_site_pairs(model):
    """Site ids ``(n, 2)`` of the elements' sites ``E/a``, ``E/b`` (``E.a``, ``E.b``), found by name."""
    import mujoco

    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i): i for i in range(model.nsite)}
    pairs = []
    for name, i in names.items():
        for sep in ("/", "."):
            if name and name.endswith(sep + "a") and name[:-1] + "b" in names:
                pairs.append((i, names[name[:-1] + "b"]))
    return np.array(pairs, dtype=int).reshape(-1, 2)


def grab(display):
    """The whole X screen as an ``(H, W, 3)`` uint8 image."""
    from PIL import ImageGrab

    return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))


def window(screen):
    """The viewer's window: the screen cropped to what is not the (black) root window."""
    drawn = np.argwhere(screen.max(axis=2) > 0)
    if not len(drawn):
        return screen
    (top, left), (bottom, right) = drawn.min(axis=0), drawn.max(axis=0) + 1
    return screen[top:bottom, left:right]


def run(args, argv):
    """On a display: the run itself. Without one: the same command in a child process on a new Xvfb server (the
    server outlives the child's connections to it, which Xlib would otherwise end the process over)."""
    if not os.environ.get("DISPLAY"):
        display, server = start_display(int(1.5 * args.width), int(1.5 * args.height))
        try:
            env = {**os.environ, "DISPLAY": display}
            env.pop("MUJOCO_GL", None)  # the viewer draws with GLFW on the display
            return subprocess.run([sys.executable, os.path.abspath(__file__), *argv], env=env).returncode
        finally:
            server.terminate()
            server.wait(timeout=10)
    return _run(args, os.environ["DISPLAY"])


def _run(args, display):
    import mujoco  # mujoco only: its entry point registers mjflex's plugin (mjflex is not imported)
    import mujoco.viewer

    model = mujoco.MjModel.from_xml_path(args.model)
    data = mujoco.MjData(model)
    if args.keyframe:
        mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, args.keyframe))
    mujoco.mj_forward(model, data)
    pairs = element_site_pairs(model)
    steps = round(args.time / model.opt.timestep)
    with mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False) as viewer:
        viewer.cam.lookat[:] = model.stat.center
        viewer.cam.distance, viewer.cam.azimuth, viewer.cam.elevation = 1.7 * model.stat.extent, 35.0, -18.0
        started = time.perf_counter()
        for k in range(steps):
            mujoco.mj_step(model, data)
            if k % 200 == 0:
                viewer.sync()
        wall = time.perf_counter() - started
        viewer.sync()
        time.sleep(args.settle)  # the viewer thread draws the last state
        image = window(grab(display))
        running = viewer.is_running()
    gap = float(np.linalg.norm(data.site_xpos[pairs[:, 0]] - data.site_xpos[pairs[:, 1]], axis=1).max())
    summary = {
        "model": os.path.relpath(args.model, ROOT), "keyframe": args.keyframe,
        "simulated_s": steps * model.opt.timestep, "steps": steps, "elements": len(pairs),
        "plugin_instances": int(model.nplugin),
        "max_site_separation_m": gap, "image_std": float(image.std()), "viewer_running": bool(running),
        "mjflex_imported": "mjflex" in sys.modules, "image_size": list(image.shape[1::-1]), "wall_s": wall,
    }  # fmt: skip
    if args.out:
        from PIL import Image

        Image.fromarray(image).save(args.out)
        with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
            json.dump({k: v for k, v in summary.items() if k != "wall_s"}, f, indent=2)
    print(json.dumps(summary))
    intact = gap <= args.max_separation and summary["image_std"] > 5.0
    if not intact:
        print(f"the model came apart or the window stayed blank: largest site separation {gap:.3g} m (allowed "
              f"{args.max_separation:g} m), image std {summary['image_std']:.3g}", file=sys.stderr)  # fmt: skip
    return 0 if intact else 1


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(ROOT, "models", "arcade.xml"))
    ap.add_argument("--keyframe", default="paper_run", help="initial state ('' for qpos0 at rest)")
    ap.add_argument("--time", type=float, default=0.02, help="simulated time before the screenshot [s]")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "viewer_arcade.png"), help="PNG to write ('' none)")
    ap.add_argument("--width", type=int, default=960, help="window width [pixels] (a new Xvfb screen is 1.5 times it)")
    ap.add_argument("--height", type=int, default=540, help="window height [pixels]")
    ap.add_argument("--settle", type=float, default=1.5, help="seconds the viewer gets to draw before the grab")
    ap.add_argument("--max-separation", type=float, default=0.01,
                    help="largest site separation of an intact model [m]")  # fmt: skip
    argv = sys.argv[1:] if argv is None else list(argv)
    return run(ap.parse_args(argv), argv)


if __name__ == "__main__":
    raise SystemExit(main())
