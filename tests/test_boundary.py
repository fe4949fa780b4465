"""The boundary a user touches: every bad input met with a clear error before anything runs or is written.

One table of ``(call, bad input, error type, message pattern)``: command-line calls end with one
line and a non-zero exit (``exit N: message``), the library raises the documented error naming the
argument or element. Each call runs in a folder holding an earlier study's results and a plain file,
which must be left exactly as they were. The property-based tests (hypothesis, deterministic) keep
records and core calls that way for inputs nobody listed.
"""

import contextlib
import io
import json
import os

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.app import cli
from mjflex.app.study import StudyError

from .models import two_body_spec

TWO_BODY = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "models", "two_body.xml"))
I3, Z3, K6 = np.eye(3), np.zeros(3), np.diag([1.0, 1.0, 1.0, 1e3, 1e3, 1e3])
EARLIER = {"out/study_two_body.md": "earlier md", "out/study_two_body.json": '{"earlier": 1}',
           "out/study_two_body.png": "earlier png", "afile": "a plain file"}  # fmt: skip


class CommandFailed(Exception):  # noqa: N818 (it stands for an exit, not a bug)
    """``python -m mjflex ...`` exited non-zero; the message is ``exit N: <its last line on stderr>``."""


def command(*argv):
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            cli.main([str(a) for a in argv])
    except SystemExit as exc:
        if exc.code in (0, None):
            return
        text = exc.code if isinstance(exc.code, str) else err.getvalue().strip().splitlines()[-1]
        assert isinstance(exc.code, int) or "\n" not in text, f"more than one line: {text!r}"
        raise CommandFailed(f"exit {1 if isinstance(exc.code, str) else exc.code}: {text}") from None


def study(*args):
    return command("study", TWO_BODY, "--out", "out", "--quiet", *args)


def _text_model(data, name="e"):
    """Two free bodies joined by element ``name`` whose text record holds ``data``."""
    xml = f"""<mujoco><worldbody>
      <body name="A"><freejoint/><geom size=".05"/><site name="{name}/a"/></body>
      <body name="B" pos="0.1 0 0"><freejoint/><geom size=".05"/><site name="{name}/b" pos="-0.1 0 0"/></body>
      </worldbody><custom><text name="mjflex:{name}" data="{data.replace('"', "&quot;")}"/></custom></mujoco>"""
    return mjflex.Flexures(mujoco.MjModel.from_xml_string(xml))


def record(**changes):
    payload = {"mjflex": 1, "method": "twist", "K": [1.0, 1.0, 1.0, 1e3, 1e3, 1e3]}
    payload.update(changes)
    return lambda: _text_model(json.dumps(payload))


def raw_record(text):
    return lambda: _text_model(text)


def flexures():
    return mjflex.Flexures(mujoco.MjModel.from_xml_path(TWO_BODY))


def add(*bodies, **kwargs):
    return lambda: mjflex.add_flexure(two_body_spec(), "x", *bodies, **{"pos": [0.1, 0.02, 0.5], "K": K6, **kwargs})


def core(function, **changes):
    """``function`` called with valid arguments, some replaced by ``changes``."""
    pose = {"R_WA": I3, "p_WA": Z3, "R_WB": I3, "p_WB": [0.01, 0.0, 0.0], "K": K6}
    args = {
        mjflex.potential: pose, mjflex.wrench_on_b: pose,
        mjflex.twist_from_transform: {"R": I3, "p": Z3}, mjflex.dual_quaternion_from_transform: {"R": I3, "p": Z3},
        mjflex.stiffness_in_frame: {"K_A": K6, "R_AB": I3, "p_AB": Z3}, mjflex.centre_of_stiffness: {"K": K6},
        mjflex.transform_from_twist: {"xi": np.zeros(6)},
    }[function]  # fmt: skip
    return lambda: function(**{**args, **changes})


BIG = 10**400
CASES = [
    # --- mjflex study: every option checked before anything is loaded, run or written
    (lambda: study("--track", "nothing"), CommandFailed, r"exit 1: error: two_body.xml: 'nothing' is neither a body"),
    (lambda: study("--frame", "nothing"), CommandFailed, r"exit 1: .*no body 'nothing' to measure poses in"),
    (lambda: study("--keyframe", "nope"), CommandFailed, r"exit 1: .*no keyframe 'nope'; its keyframes are \['swing"),
    (lambda: study("--steps", 0, 1e-5), CommandFailed, r"exit 1: error: --steps\[0\] must be > 0; got 0.0"),
    (lambda: study("--steps", "nan"), CommandFailed, r"exit 1: error: --steps\[0\] must be a finite number"),
    (lambda: study("--targets", -5), CommandFailed, r"exit 1: error: --targets\[0\] must be > 0 and <= 1; got -5"),
    (lambda: study("--targets", 0), CommandFailed, r"exit 1: error: --targets\[0\] must be > 0 and <= 1; got 0"),
    (lambda: study("--targets", 200), CommandFailed, r"exit 1: error: --targets\[0\] must be > 0 and <= 1; got 200"),
    (lambda: study("--reference-tol", -1), CommandFailed, r"exit 1: error: --reference-tol must be > 0 and < 1"),
    (lambda: study("--bisect", -1), CommandFailed, r"exit 1: error: --bisect must be >= 0; got -1"),
    (lambda: study("--max-refinements", -1), CommandFailed, r"exit 1: error: --max-refinements must be >= 0"),
    (lambda: study("--duration", "nan"), CommandFailed, r"exit 1: error: --duration must be a finite number; got nan"),
    (lambda: study("--duration", -1), CommandFailed, r"exit 1: error: --duration must be > 0; got -1"),
    (lambda: study("--max-step", "inf"), CommandFailed, r"exit 1: error: --max-step must be a finite number"),
    (lambda: study("--min-step", 1e-3, "--max-step", 1e-4), CommandFailed, r"exit 1: .*--min-step 0.001 s is above"),
    (lambda: study("--steps", 1e-4, "--max-step", 1e-3), CommandFailed, r"exit 1: .*--max-step .* would be ignored"),
    (lambda: study("--samples", 0), CommandFailed, r"exit 1: error: --samples must be >= 1; got 0"),
    (lambda: study("--repeat", 0), CommandFailed, r"exit 1: error: --repeat must be >= 1; got 0"),
    (lambda: study("--max-run-wall", 0), CommandFailed, r"exit 1: error: --max-run-wall must be > 0"),
    (lambda: command("study", TWO_BODY, "--out", "afile"), CommandFailed, r"exit 1: .*--out 'afile' is a file, not a"),
    (lambda: command("study", TWO_BODY, "--out", "afile/x"), CommandFailed, r"exit 1: .*is a file, so the folder"),
    (lambda: mjflex.study(TWO_BODY, targets=[0.1, 2.0]), StudyError, r"targets\[1\] must be > 0 and"),
    (lambda: mjflex.study(TWO_BODY, track="link"), TypeError, r"track must be a non-empty list of body or site names"),
    (lambda: mjflex.study(TWO_BODY, repeat=2.5), TypeError, r"repeat must be an integer; got 2.5"),
    (lambda: mjflex.study(TWO_BODY, qvel=np.ones(12) * 1j), StudyError, r"two_body.xml: qvel holds complex numbers"),
    (lambda: mjflex.study(TWO_BODY, out="afile"), StudyError, r"out 'afile' is a file, not a folder"),
    (lambda: mjflex.study(TWO_BODY, track=["nothing"], out="new/x"), StudyError, r"'nothing' is neither a body"),
    # --- --out naming a file, and options of the other commands
    (lambda: command("sweep", "--out", "afile"), CommandFailed, r"exit 1: error: --out 'afile' is a file, not a"),
    (lambda: command("demo", "--out", "afile"), CommandFailed, r"exit 1: error: --out 'afile' is a file, not a folder"),
    (lambda: command("sweep", "--duration", "nan", "--out", "new"), CommandFailed, r"exit 2: .*--duration must be a"),
    (lambda: command("demo", "--width", 1, "--out", "new"), CommandFailed, r"exit 1: .*--width and --height must be"),
    (lambda: command("demo", "--fps", 0, "--out", "new"), CommandFailed, r"exit 2: .*argument --fps: must be a posit"),
    (lambda: command("simulate", TWO_BODY, "--video", "v.mp4", "--width", 70000), CommandFailed,
     r"exit 1: error: --width 70000 is larger than the \d+ pixels the OpenGL here renders offscreen"),
    (lambda: command("simulate", TWO_BODY, "--video", "v.mp4", "--height", 2**40), CommandFailed,
     r"exit 1: error: --height \d+ is larger than the \d+ pixels"),
    (lambda: command("simulate", TWO_BODY, "--fps", 0), CommandFailed, r"exit 2: .*argument --fps: must be a positive"),
    (lambda: command("simulate", TWO_BODY, "--width", "2.5"), CommandFailed, r"exit 2: .*--width: expected a whole"),
    (lambda: command("simulate", TWO_BODY, "--duration", -1), CommandFailed, r"exit 2: .*--duration: must be a posit"),
    (lambda: command("simulate", TWO_BODY, "--timestep", 0), CommandFailed, r"exit 2: .*--timestep: must be a posit"),
    (lambda: command("simulate", TWO_BODY, "--json", "no/such/s.json"), CommandFailed, r"exit 1: .*does not exist"),
    # --- mjflex.reduce: only the documented values
    (lambda: mjflex.reduce(TWO_BODY, 500, plane="none"), ValueError, r"plane must be None, 'auto' or a .*'none'"),
    (lambda: mjflex.reduce(TWO_BODY, 500, plane="off"), ValueError, r"got 'off' \(plane=None reduces in 3-D\)"),
    (lambda: mjflex.reduce(TWO_BODY, 500, plane="atuo"), ValueError, r"plane must be None, 'auto' or .*got 'atuo'"),
    (lambda: mjflex.reduce(TWO_BODY, 500, plane=[0, 0, 0]), ValueError, r"nonzero normal vector"),
    (lambda: mjflex.reduce(TWO_BODY, keep_below_hz="500"), TypeError, r"keep_below_hz must be a number; got the text"),
    (lambda: mjflex.reduce(TWO_BODY, keep_below_hz=float("nan")), ValueError, r"keep_below_hz must be a finite"),
    (lambda: mjflex.reduce(TWO_BODY, 500, max_joints=2.0), TypeError, r"max_joints must be an integer; got 2.0"),
    (lambda: mjflex.reduce(TWO_BODY, 500, freq_tol=True), TypeError, r"freq_tol must be a number; got the boolean"),
    (lambda: mjflex.reduce(TWO_BODY, 500, loops=["auto"]), ValueError, r"loops must be one of"),
    # --- the core: None only where documented optional; no complex, booleans or text
    (core(mjflex.potential, R_WA=None), TypeError, r"R_WA is None, but it is required.*no argument here may be None"),
    (core(mjflex.potential, K=None), TypeError, r"K is None, but it is required: an array of shape \(\.\.\., 6, 6\)"),
    (core(mjflex.wrench_on_b, p_WB=None), TypeError, r"p_WB is None, but it is required: .*only B, w_WA"),
    (core(mjflex.wrench_on_b, K=K6 + 0j), ValueError, r"K holds complex numbers \(dtype complex128\).*np\.real"),
    (core(mjflex.potential, p_WB=[0.01j, 0, 0]), ValueError, r"p_WB\[0\] is the complex number 0\.01j"),
    (core(mjflex.twist_from_transform, R=I3.astype(complex)), ValueError, r"R holds complex numbers"),
    (core(mjflex.stiffness_in_frame, K_A=K6.astype(np.complex64)), ValueError, r"K_A holds complex numbers"),
    (core(mjflex.transform_from_twist, xi=np.ones(6) * 1j), ValueError, r"xi holds complex numbers"),
    (core(mjflex.centre_of_stiffness, K=K6 > 0), ValueError, r"K holds booleans \(dtype bool\)"),
    (core(mjflex.potential, p_WA=[True, 0.0, 0.0]), ValueError, r"p_WA\[0\] is the boolean True"),
    (core(mjflex.twist_from_transform, p=np.array(["0.1", "0", "0"])), ValueError, r"p holds text \(dtype <U3\)"),
    (core(mjflex.dual_quaternion_from_transform, p=[0.1, "0", 0]), ValueError, r"p\[1\] is the text '0'"),
    (core(mjflex.potential, p_WB=[BIG, 0, 0]), ValueError, r"p_WB\[0\] is an integer of 401 digits: beyond float64"),
    # --- run-time switches: bools only; an element by name or row
    (lambda: flexures().set_enabled("hinge", "false"), TypeError, r"enabled must be True or False; got 'false' \("),
    (lambda: flexures().set_viscous("hinge", "off"), TypeError, r"viscous must be True or False; got 'off'"),
    (lambda: flexures().set_enabled("hinge", 0), TypeError, r"enabled must be True or False; got 0 \(int\)"),
    (lambda: flexures().set_enabled(1, False), IndexError, r"flexure index 1 is out of range: there are 1 \(0"),
    (lambda: flexures().set_enabled(0.0, False), TypeError, r"an element is named by its name .* or its row \(int\)"),
    (lambda: flexures().set_method(None, "twist"), TypeError, r"an element is named by its name"),
    # --- element records: the rules of mjflex.mjcf.schema, each naming the element
    (record(K=[True, 1, 1, 1, 1, 1]), mjflex.ModelError, r"flexure 'e': .*K\[0\] is the boolean True"),
    (record(K=["0.3", 1, 1, 1, 1, 1]), mjflex.ModelError, r"flexure 'e': .*K\[0\] is the text '0\.3'"),
    (record(K=[None, 1, 1, 1, 1, 1]), mjflex.ModelError, r"flexure 'e': .*K\[0\] is None"),
    (record(K=None), mjflex.ModelError, r"flexure 'e': K is missing: give 6 numbers \(the diagonal\)"),
    (raw_record('{"mjflex": 1, "K": [1, 1, 1, 1, 1, 1], "K": [2, 2, 2, 2, 2, 2]}'), mjflex.ModelError,
     r"flexure 'e': .*the key 'K' is given twice in one object; keep one"),
    (raw_record('{"mjflex": 1, "K": [1, 1, 1, 1, 1, 1], "source": {"a": 1, "a": 2}}'), mjflex.ModelError,
     r"flexure 'e': .*the key 'a' is given twice"),
    (lambda: _text_model(json.dumps({"mjflex": 1, "K": [1] * 6}), name=""), mjflex.ModelError,
     r"flexure '': .*the element name is empty"),
    (record(mjflex=True), mjflex.ModelError, r"flexure 'e': .*\"mjflex\" must be the schema version 1; got True"),
    (record(mjflex=1.0), mjflex.ModelError, r"flexure 'e': .*\"mjflex\" must be the schema version 1; got 1\.0"),
    (raw_record('{"mjflex": 1, "K": [1, 1, 1, 1, 1, 1], "strain_per_radian": Infinity}'), mjflex.ModelError,
     r"flexure 'e': .*\"strain_per_radian\" is Infinity, which is not a JSON number"),
    (raw_record('{"mjflex": 1, "K": [1, 1, 1, 1, 1, 1], "source": {"E": [NaN]}}'), mjflex.ModelError,
     r"flexure 'e': .*\"source\"\[\"E\"\]\[0\] is NaN"),
    (record(K=[BIG, 1, 1, 1, 1, 1]), mjflex.ModelError, r"flexure 'e': .*K\[0\] is an integer of 401 digits"),
    (record(B=[1, 1, 1, 1, 1, -BIG]), mjflex.ModelError, r"flexure 'e': .*B\[5\] is an integer of 401 digits"),
    (record(strain_per_radian=BIG), mjflex.ModelError, r"flexure 'e': .*strain_per_radian is an integer of 401 dig"),
    (record(strain_per_radian=True), mjflex.ModelError, r"flexure 'e': .*strain_per_radian is the boolean True"),
    (record(strain_per_radian=-1), mjflex.ModelError, r"flexure 'e': strain_per_radian must be a finite number >= 0"),
    (record(enabled="false"), mjflex.ModelError, r"flexure 'e': .*\"enabled\" must be true or false; got 'false'"),
    (record(order=BIG, terms={"exponents": [[4, 0, 0, 0, 0, 0]], "coefficients": [1.0]}), mjflex.ModelError,
     r"flexure 'e': order has '1000000000.*', which is not an integer"),
    (record(order=4, terms={"exponents": [[True, 3, 0, 0, 0, 0]], "coefficients": [1.0]}), mjflex.ModelError,
     r"flexure 'e': .*exponents\[0, 0\] is the boolean True"),
    (record(order=4, terms={"exponents": [[BIG, 0, 0, 0, 0, 0]], "coefficients": [1.0]}), mjflex.ModelError,
     r"flexure 'e': .*exponents\[0, 0\] is an integer of 401 digits"),
    (record(method=["twist"]), mjflex.ModelError, r"flexure 'e': .*\"method\" must be a string; got \['twist'\]"),
    (record(method="twst"), mjflex.ModelError, r"flexure 'e': unknown method 'twst'. Use method \"twist\" or"),
    # --- add_flexure: the argument named, the spec untouched
    (add(None, "B"), TypeError, r"body_a must be a body name \(str; 'world' grounds\) or a mujoco\.MjsBody.*None"),
    (add("A", 3), TypeError, r"body_b must be a body name .*got 3 \(int\)"),
    (add(1.5, "B"), TypeError, r"body_a must be a body name .*got 1\.5 \(float\)"),
    (add("A", "B", enabled="false"), TypeError, r"enabled must be True or False; got 'false'"),
    (add("A", "B", strain_per_radian=float("inf")), ValueError, r"strain_per_radian must be a finite number"),
    (add("A", "B", source={"a": float("nan")}), ValueError, r"flexure 'x': source must be one JSON object.*no NaN"),
    (add("A", "B", source={"a": np.ones(2)}), TypeError, r"flexure 'x': source must hold JSON values only"),
    (add("A", "B", K=[True] * 6), ValueError, r"K of flexure 'x'\[0\] is the boolean True"),
    (lambda: mjflex.add_flexure(two_body_spec(), "", "A", "B", pos=Z3, K=K6), TypeError, r"name must be a non-empty"),
]  # fmt: skip


@pytest.fixture
def earlier_results(tmp_path, monkeypatch):
    """A folder with an earlier study's results and a plain file; returns its files and their contents."""
    monkeypatch.chdir(tmp_path)
    os.makedirs("out")
    for path, text in EARLIER.items():
        with open(path, "w") as f:
            f.write(text)
    return tmp_path


def _files(root):
    out = {}
    for folder, _, names in os.walk(root):
        for name in names:
            path = os.path.join(folder, name)
            with open(path, "rb") as f:
                out[os.path.relpath(path, root)] = f.read()
    return out


@pytest.mark.parametrize("call, error, match", CASES, ids=[f"{i:02d}" for i in range(len(CASES))])
def test_bad_input_is_refused_clearly_and_writes_nothing(call, error, match, earlier_results):
    before = _files(earlier_results)
    with pytest.raises(error, match=match) as exc:
        call()
    assert len(str(exc.value)) < 1200, f"message of {len(str(exc.value))} characters"
    assert _files(earlier_results) == before  # nothing written, earlier results untouched
    assert sorted(os.listdir(earlier_results)) == ["afile", "out"]  # no folder created either


def test_a_huge_bad_value_is_quoted_shortened():
    """A 500 kB value in a record: the message quotes it cut short and says how long it was."""
    huge = {"mjflex": 1, "K": [1.0] * 6, "source": "not an object " * 40_000}
    with pytest.raises(
        mjflex.ModelError, match=r'"source" must be a JSON object; got .*\.\.\. \(\d{6} characters\)'
    ) as e:
        _text_model(json.dumps(huge))
    assert len(str(e.value)) < 400
    with pytest.raises(ValueError, match=r"p\[0\] is the text 'xxxxx.*\.\.\. \(\d+ characters\)") as e:
        mjflex.twist_from_transform(I3, ["x" * 500_000, 0, 0])
    assert len(str(e.value)) < 400


def test_elements_by_row_and_switches_by_bool():
    """An int row names an element as well as its name does; numpy bools are bools."""
    flex = flexures()
    flex.set_enabled(0, False)
    flex.set_viscous(np.int64(0), np.bool_(False))
    assert not flex.enabled[0] and not flex.viscous[0]
    flex.set_enabled("hinge", np.True_)
    assert flex.enabled[0] and flex.index(0) == flex.index("hinge") == 0


def test_add_flexure_leaves_the_spec_untouched_when_it_refuses():
    spec = two_body_spec()
    before = spec.to_xml()
    for kwargs in ({"source": {"a": float("nan")}}, {"enabled": "yes"}, {"strain_per_radian": -1.0}):
        with pytest.raises((TypeError, ValueError)):
            mjflex.add_flexure(spec, "x", "A", "B", pos=[0.1, 0.02, 0.5], K=K6, **kwargs)
    assert spec.to_xml() == before


def test_plane_values_that_are_documented_still_work():
    """None (3-D) and 'auto' as before: two_body's planar keyframe keeps its modes in 3-D."""
    three_d = mjflex.reduce(TWO_BODY, 500.0, verify=False)
    auto = mjflex.reduce(TWO_BODY, 500.0, plane="auto", verify=False)
    assert three_d.details["plane"] is None and auto.details["plane"] is not None


def test_help_shows_every_option_with_its_default():
    """Every option of every command has help text; it states the default (the value itself when there is one)."""
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name, sub in commands.items():
        text = " ".join(sub.format_help().split())
        for action in sub._actions:
            if not action.option_strings or action.dest == "help":
                continue
            option = action.option_strings[0]
            assert action.help, f"{name} {option} has no help"
            if isinstance(action, cli.argparse._StoreTrueAction):
                continue
            helped = " ".join(sub.formatter_class("x")._get_help_string(action).split())
            assert "".join(helped.split()) in "".join(text.split())  # as shown (argparse wraps at hyphens)
            assert "default" in helped, f"{name} {option}: no default in {helped!r}"
            if action.default is not None:
                shown = action.default if isinstance(action.default, str) else None
                if isinstance(action.default, int | float) and not isinstance(action.default, bool):
                    shown = f"{action.default:g}"
                if shown is not None:
                    assert (
                        f"default {shown}" in helped or f"{shown}', the default" in helped or "(default)" in helped
                    ), f"{name} {option}: default {shown} not shown in {helped!r}"


def test_stable_everywhere_suggests_what_was_given():
    """With --steps given the advice is a larger step in --steps, not --max-step (which would be ignored)."""
    from mjflex.app.study import Limit

    given = Limit("full", "twist", "rk4", 1e-5, None, steps_given=True)
    default = Limit("full", "twist", "rk4", 1e-5, None)
    assert "add a larger step to --steps" in given.text() and "--max-step" not in given.text()
    assert "widen with --max-step" in default.text()


def test_a_study_replaces_its_files_together(tmp_path, monkeypatch):
    """The .md/.json/.png of a study are written beside and renamed at the end: a failure while writing leaves the
    earlier set whole; a new set without a plot removes the earlier plot and the .partial files of a stopped study."""
    from mjflex.app.study import Row, StudyResult, _plot

    earlier = {"study_m.md": "old", "study_m.json": "{}", "study_m.png": "old", "study_m.partial.json": "{}"}
    for name, text in earlier.items():
        (tmp_path / name).write_text(text)
    result = StudyResult("m.xml", rows=[Row("full", "twist", "rk4", 1e-4, "ok")])

    def broken_plot(result, path):
        with open(path, "w") as f:
            f.write("half a plot")
        raise RuntimeError("disk full")

    monkeypatch.setattr(_plot, "pareto_plot", broken_plot)
    with pytest.raises(RuntimeError, match="disk full"):
        result.write(tmp_path)
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == earlier  # untouched, no temporary file left
    result.rows = []  # nothing to plot
    paths = result.write(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study_m.json", "study_m.md"]
    assert [os.path.basename(p) for p in paths] == ["study_m.md", "study_m.json"]
    assert json.loads((tmp_path / "study_m.json").read_text())["model"] == "m.xml"
    stopped = result.write(tmp_path, partial=True)
    assert [os.path.basename(p) for p in stopped] == ["study_m.partial.md", "study_m.partial.json"]
    assert (tmp_path / "study_m.md").read_text() == result.to_markdown()  # the complete set stays
