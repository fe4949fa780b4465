"""Command line: ``python -m mjflex simulate MODEL.xml ...``, ``demo``, ``study``, ``sweep`` and ``convert``."""

import argparse
import datetime
import inspect
import json
import math
import os
import shlex
import sys
import time
from dataclasses import asdict

from . import render
from .arcade import arcade_source
from .output import file_problem, folder_problem
from .runs import check_video_size, exit_on_divergence, load_model, run_model
from .simulate import INTEGRATORS
from .timing import process_start

VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov", ".avi", ".webm", ".gif")


def _positive(convert, noun, rule):
    """argparse type: a positive number of ``convert`` (float: finite; 0 and negatives rejected)."""

    def parse(text):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {noun}, got {text!r}") from None
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"must be {rule}; got {text!r}")
        return value

    return parse


positive_float = _positive(float, "a number", "a positive, finite number")
positive_int = _positive(int, "a whole number", "a positive whole number")


def check_output(path, option, suffixes=None, *, folder=False):
    """Raise SystemExit unless ``path`` can be written: a file in an existing folder, or a ``folder`` that is one or
    can be created; checked before a run."""
    problem = folder_problem(path, option) if folder else path is not None and file_problem(path, option, suffixes)
    if problem:
        raise SystemExit(f"error: {problem}")


def provenance(argv=None):
    """``{"command", "date"}``: the command line (``python -m mjflex ...``) and UTC start time, for JSON reports."""
    args = sys.argv[1:] if argv is None else [str(a) for a in argv]
    date = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    return {"command": shlex.join(["python", "-m", "mjflex", *args]), "date": date}


def _simulate_command(args):
    started = time.perf_counter()
    check_output(args.json, "--json")
    check_output(args.video, "--video", VIDEO_SUFFIXES)
    model = load_model(args.model, args.method, not args.no_damping)
    with exit_on_divergence(os.path.basename(args.model)):
        summary, _, _ = run_model(
            model, os.path.basename(args.model), duration=args.duration, integrator=args.integrator,
            timestep=args.timestep, keyframe=args.keyframe, video=args.video, width=args.width, height=args.height,
            fps=args.fps, slowdown=args.slowdown, progress=not args.quiet,
        )  # fmt: skip
    print(summary.text())
    print(f"wall time of the whole command {time.perf_counter() - started:.3g} s (loading, run, sampling, rendering)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(asdict(summary), f, indent=2)


def _demo_command(args):
    from .demo import command_clock, run_demo, video_size  # matplotlib and the figures load only for this command

    clock = command_clock(args.process_started)
    check_output(args.out, "--out", folder=True)
    with clock.phase("rendering set-up"):  # the GL's kind sets the default size; its limit is checked before the run
        try:
            width, height = video_size(args.width, args.height, render.gl_info())
        except RuntimeError as exc:
            raise SystemExit(f"error: no video can be rendered here: {exc}") from None
        check_video_size(width, height)
    os.makedirs(args.out, exist_ok=True)
    run_demo(args.out, duration=args.duration, width=width, height=height, fps=args.fps,
             slowdown=args.slowdown, quality=args.quality, progress=not args.quiet, clock=clock)  # fmt: skip


def _floats(text):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


class HelpFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless its text states the default itself."""

    def _get_help_string(self, action):
        text = action.help or ""
        stated = "(default" in text or "; default" in text
        if stated or not action.option_strings or action.default in (None, False, argparse.SUPPRESS):
            return text
        values = action.default if isinstance(action.default, list | tuple) else [action.default]
        shown = ("," if action.type is _floats else " ").join(
            f"{v:g}" if isinstance(v, float) else str(v) for v in values
        )
        return f"{text} (default {shown.replace('%', '%%')})"


def _sweep_parser(sub):
    sw = sub.add_parser("sweep", help="ARCADE: cylinder stroke vs leaf-spring stiffness and damping, over a grid",
                        formatter_class=HelpFormatter)  # fmt: skip
    sw.add_argument("--leaf-scale", type=_floats, default=[0.5, 1.0, 2.0, 4.0],
                    help="leaf-spring stiffness scales, comma-separated")  # fmt: skip
    sw.add_argument("--beta", type=_floats, default=[0.0, 2e-6, 1e-5, 4e-5],
                    help="Rayleigh damping B = beta K of every flexure [s], comma-separated")  # fmt: skip
    sw.add_argument("--duration", type=float, default=0.03, help="simulated time per variant [s]")
    sw.add_argument("--samples", type=positive_int, default=61, help="observations from 0 to duration")
    sw.add_argument("--executor", choices=["batch", "pool", "dask", "warp"], default="batch",
                    help="batch: Batch threads here; pool: spawn process pool; dask: local cluster; warp: MuJoCo "
                    'Warp, the variants as its worlds (float32; pip install "mjflex[warp]")')  # fmt: skip
    sw.add_argument("--device", help="Warp device of --executor warp, e.g. cpu or cuda:0 (default: Warp's default, "
                    "a GPU where there is one)")  # fmt: skip
    sw.add_argument("--workers", type=positive_int, default=2, help="processes for pool/dask")
    sw.add_argument("--threads", type=int, help="Batch threads per process (default: all CPUs here, 1 per worker)")
    sw.add_argument("--out", default="out", help="folder for sweep_arcade.nc, .png and .json, created if missing")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")


def _study_options(args, study):
    """``study``'s keyword options from the parsed ``args`` (its own defaults for those the command line lacks)."""
    options = {k: p.default for k, p in inspect.signature(study).parameters.items() if p.kind == p.KEYWORD_ONLY}
    del options["out"], options["progress"]
    options.update({k: getattr(args, k) for k in options if hasattr(args, k)})
    return options | {"variants": [] if args.no_variants else None}


def _docs_parser(sub):
    p = sub.add_parser("docs", help="build the documentation site (needs a source checkout and the docs extra)",
                       description="Build the HTML documentation from docs/ of the source checkout with Sphinx, "
                       "executing the tutorials; strict by default: warnings, broken references and failing "
                       'examples are errors. Needs: pip install -e ".[docs]".',
                       formatter_class=HelpFormatter)  # fmt: skip
    p.add_argument("--out", default=os.path.join("out", "docs"), help="output folder (default out/docs)")
    p.add_argument("--no-strict", action="store_true", help="report warnings without failing")
    p.add_argument("--no-tutorials", action="store_true", help="do not execute the tutorials (a quick draft)")


def _study_command(args):
    from .study import StudyError, check_options, study  # tqdm and the study's modules load only for this command

    options = _study_options(args, study)
    try:  # every option, before anything is loaded, run or written
        check_options(options, args.out, spell=lambda name: "--" + name.replace("_", "-"))
    except StudyError as exc:
        raise SystemExit(f"error: {exc}") from None
    model = arcade_source()[0] if args.model == "arcade" else args.model
    try:
        result = study(model, **options, progress=not args.quiet)
    except StudyError as exc:
        if exc.partial is None:  # the model, its state or a name was refused before any run
            raise SystemExit(f"error: {exc}") from None
        exc.partial.command = args.provenance["command"]
        exc.paths = exc.partial.write(args.out, partial=True)
        raise SystemExit(
            f"error: {exc} Partial results written to {', '.join(exc.paths)} (earlier results left as they were)."
        ) from None
    result.command = args.provenance["command"]
    paths = result.write(args.out)
    print("\n".join(result.summary_lines()))
    print("\n".join(result.recommendation()))
    for limit in result.limits:
        print(f"largest stable step, {limit.text()}")
    print(f"wrote {', '.join(paths)}")
    if result.message:
        raise SystemExit(f"error: {result.message}")


def _study_parser(sub):
    p = sub.add_parser("study", help="measure speed vs accuracy of methods, integrators, steps and model variants",
                       description="Measure the speed-accuracy trade of simulating MODEL's flexures (see "
                       "mjflex.app.study): a converged RK4 reference, then every candidate's cost, error and "
                       "largest stable step; writes a markdown table, JSON and a Pareto plot to --out. Every "
                       "option is checked before anything runs or is written.",
                       formatter_class=HelpFormatter)  # fmt: skip
    p.add_argument(
        "model", help="MJCF file with mjflex elements and a keyframe to start from ('arcade': the showcase model)"
    )
    p.add_argument("--keyframe", help="initial state (default: the first keyframe)")
    p.add_argument("--duration", type=float, help="simulated time [s] (default: one period of the lowest mode)")
    p.add_argument("--track", nargs="+", metavar="NAME", help="bodies or sites to compare (default: all bodies)")
    p.add_argument("--frame", default="auto", help="body the poses are taken in, 'world' or 'auto' (default)")
    p.add_argument("--methods", nargs="+", choices=["twist", "dualquat"], default=["twist", "dualquat"],
                   help="element methods to compare")  # fmt: skip
    p.add_argument("--integrators", nargs="+", choices=sorted(INTEGRATORS),
                   default=["rk4", "euler", "implicitfast", "discrete"],
                   help="MuJoCo integrators to compare")  # fmt: skip
    p.add_argument("--steps", nargs="+", type=float, metavar="H", help="candidate time steps [s] (default: "
                   "--step-count log-spaced steps from past the stability limit down); excludes "
                   "--max-step/--min-step")  # fmt: skip
    p.add_argument("--step-count", type=int, default=6, help="number of default steps, factors of 2 apart")
    p.add_argument(
        "--max-step",
        type=float,
        help="largest default step [s] (default: twice RK4's limit for the "
        "fastest rate of the linearized model, damping included)",
    )
    p.add_argument("--min-step", type=float,
                   help="smallest default step [s] (default: --max-step / 2^(--step-count - 1))")  # fmt: skip
    p.add_argument("--no-variants", action="store_true", help="compare the model as given only")
    p.add_argument("--repeat", type=int, default=3, help="interleaved timing rounds, median reported")
    p.add_argument("--bisect", type=int, default=8, help="most bisection runs per stability limit (0: none, the "
                   "limits are bracketed by the candidate steps alone; default 8)")  # fmt: skip
    p.add_argument("--reference-tol", type=float, default=1e-6,
                   help="agreement (relative pose error) of two reference refinements that stops them, "
                   "in (0, 1)")  # fmt: skip
    p.add_argument("--max-refinements", type=int, default=5, help="most halvings of the reference step")
    p.add_argument("--reference-step", type=float, help="first reference step [s] (default: the model's)")
    p.add_argument("--samples", type=int, default=200, help="sample intervals over the duration")
    p.add_argument("--max-run-wall", type=float, default=120.0, help="wall-time budget of one run [s]")
    p.add_argument("--targets", nargs="+", type=float, default=[0.1, 0.01, 1e-4],
                   help="relative pose-error targets of the recommendation, each in (0, 1]: "
                   "0.01 = 1 percent")  # fmt: skip
    p.add_argument("--clock", choices=["cpu", "wall"], default="cpu", help="cost measured as the stepping thread's "
                   "CPU time ('cpu', the default: an idle core's wall time, robust on a shared machine) or wall time "
                   "('wall')")  # fmt: skip
    p.add_argument("--out", default="out", help="folder for study_<model>.md/.json/.png, created if missing; a "
                   "study that stops early writes study_<model>.partial.* there instead (default out)")  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _convert_parser(sub):
    p = sub.add_parser("convert", help="write a model's elements as engine-plugin instances or as text records",
                       description="Turn the text-record elements of an MJCF file into instances of the engine "
                       "plugin mjflex.flexure (--to plugin: the file then runs in any MuJoCo program, e.g. python -m "
                       "mujoco.viewer), or back (--to record), losslessly: every parameter keeps every digit, the rest "
                       "of the file keeps its text (trees joined by plugin elements get sleep=\"never\"). The result "
                       "is compiled and compared with the input before OUTPUT is written.",
                       formatter_class=HelpFormatter)  # fmt: skip
    p.add_argument("input", help="MJCF file with mjflex elements")
    p.add_argument("output", help="MJCF file to write (may be INPUT: converted in place)")
    p.add_argument("--to", choices=["plugin", "record"], default="plugin", help="the form to write")


def _convert_command(args):
    from ..runtime.files import ConversionError, convert_file  # late: for `convert` only (--help stays light)

    try:
        names = convert_file(args.input, args.output, to=args.to)
    except ConversionError as exc:
        raise SystemExit(f"error: {exc}") from None
    form = "mjflex.flexure plugin instances" if args.to == "plugin" else "text records"
    shown = ", ".join(names[:4]) + (f", ... ({len(names)} in all)" if len(names) > 4 else "")
    print(f"wrote {args.output}: {len(names)} element(s) as {form}: {shown}")


def build_parser():
    """The ``python -m mjflex`` argument parser (also read by the documentation's command-line reference)."""
    ap = argparse.ArgumentParser(prog="python -m mjflex", description="Visco-elastic flexures for MuJoCo.")
    sub = ap.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="simulate an MJCF model with mjflex elements", formatter_class=HelpFormatter)
    sim.add_argument("model", help="MJCF file")
    sim.add_argument("--duration", type=positive_float, default=0.01, help="simulated time [s]")
    sim.add_argument("--video", help="write an MP4 (or .mkv, .mov, .avi, .webm, .gif) of the run here (default: no "
                     "video)")  # fmt: skip
    sim.add_argument("--method", choices=["twist", "dualquat"],
                     help="override every element's method (default: each element's own)")  # fmt: skip
    sim.add_argument("--integrator", choices=sorted(INTEGRATORS),
                     help="override the model's integrator (default: the model's)")  # fmt: skip
    sim.add_argument("--timestep", type=positive_float, help="override the model's time step [s] (default: the "
                     "model's)")  # fmt: skip
    sim.add_argument(
        "--keyframe", help="initial state: a name, or an index (default: the first keyframe, else qpos0 at rest)"
    )
    sim.add_argument("--no-damping", action="store_true", help="switch off every element's viscous part")
    sim.add_argument("--json", help="write the summary as JSON here (default: no JSON)")
    demo = sub.add_parser("demo", help="the paper's ARCADE run: video, Fig. 4-like panels, energy and stroke plots",
                          formatter_class=HelpFormatter)  # fmt: skip
    demo.add_argument("--out", default="out", help="folder for arcade.mp4, the panels, the plots and "
                      "arcade_summary.json, created if missing")  # fmt: skip
    demo.add_argument("--duration", type=positive_float, default=0.08, help="simulated time [s]")
    _study_parser(sub)
    for p in (sim, demo):
        size = "1280x720, 960x540 where the GL renders in software; one given, 16:9" if p is demo else None
        p.add_argument("--width", type=positive_int, default=None if p is demo else 640,
                       help=f"video width [pixels] (default {size or 640})")  # fmt: skip
        p.add_argument("--height", type=positive_int, default=None if p is demo else 360,
                       help=f"video height [pixels] (default {size or 360})")  # fmt: skip
        p.add_argument("--quality", choices=render.QUALITIES, default="auto",
                       help="full: multisampling, skybox, shadows, reflections; fast: none of them (what costs "
                       "most where the GL renders in software, e.g. Mesa's llvmpipe without a GPU); auto (default): "
                       "fast on a software GL, full elsewhere")  # fmt: skip
        p.add_argument("--fps", type=positive_int, default=30, help="video frames per second")
        p.add_argument("--slowdown", type=positive_float, default=100.0, help="slow-motion factor of the video")
        p.add_argument("--quiet", action="store_true", help="no progress bar")
    _sweep_parser(sub)
    _convert_parser(sub)
    _docs_parser(sub)
    return ap


def main(argv=None):
    ap = build_parser()
    args = ap.parse_args(argv)
    args.provenance = provenance(argv)
    args.process_started = process_start() if argv is None else None  # the command line: start-up is timed
    if args.command == "docs":
        from .docs import build_docs  # late: Sphinx is the docs extra's, for `docs` only

        raise SystemExit(build_docs(args.out, strict=not args.no_strict, tutorials=not args.no_tutorials))
    if args.command == "study":
        _study_command(args)
    elif args.command == "convert":
        _convert_command(args)
    elif args.command == "sweep":
        if args.threads is not None and args.threads < 0:
            ap.error("--threads must be >= 0 (0: all CPUs)")
        if args.device is not None and args.executor != "warp":
            ap.error("--device is for --executor warp")
        if not (args.duration >= 0 and math.isfinite(args.duration)):
            ap.error(f"--duration must be a finite number of seconds >= 0; got {args.duration:g}")
        check_output(args.out, "--out", folder=True)
        from .sweep.arcade import run_arcade_sweep  # late: xarray and the sweep machinery, for `sweep` only

        try:
            run_arcade_sweep(args.out, leaf_scale=args.leaf_scale, beta=args.beta, duration=args.duration,
                             samples=args.samples, executor=args.executor, workers=args.workers, device=args.device,
                             threads=args.threads, progress=not args.quiet, provenance=args.provenance)  # fmt: skip
        except ValueError as exc:
            raise SystemExit(f"error: {exc}") from None
    elif args.command == "simulate":
        _simulate_command(args)
    else:
        _demo_command(args)
