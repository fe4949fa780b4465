"""Plugin models everywhere a user touches them: building, converting, sleeping, composing, the command line.

The text-record and plugin forms of one element run the same C loop on the same element table,
so the forms are compared bit for bit (trajectories, records), not to a tolerance.
"""

import copy
import json
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

import mjflex
import mjflex_plugin
from mjflex.app import cli, runs
from mjflex.mjcf import elements, schema
from mjflex.native import library as _native
from mjflex.runtime.files import same_record
from tests.models import B_DEMO, K_DEMO, push_after_rest, two_body_spec
from tests.plugin_models import MODELS, as_plugins, as_records, assert_not_diverged, polynomial_terms

pytestmark = pytest.mark.usefixtures("clean_callback")
ROOT = os.path.join(os.path.dirname(__file__), "..")
ARCADE = os.path.join(MODELS, "arcade.xml")
TWO_BODY = os.path.join(MODELS, "two_body.xml")


def _trajectory(model, qvel=None, steps=1000, key=None):
    data = mujoco.MjData(model)
    if key is not None:
        mujoco.mj_resetDataKeyframe(model, data, key)
    if qvel is not None:
        data.qvel[:] = qvel
    out = np.empty((steps, model.nq + model.nv))
    for i in range(steps):
        mujoco.mj_step(model, data)
        out[i, : model.nq], out[i, model.nq :] = data.qpos, data.qvel
    assert_not_diverged(data, f"the run of {steps} steps")
    return out


def _records(model):
    flex = mjflex.Flexures(model)
    return flex, dict(zip(flex.names, flex.records, strict=True))


# ------------------------------------------------------------------ 1. add_flexure's default and the fallback


def test_add_flexure_writes_plugin_elements_by_default():
    spec = two_body_spec(B=B_DEMO, kind="plugin")
    default = mujoco.MjSpec()
    for body in ("A", "B"):
        b = default.worldbody.add_body(name=body, pos=[0.2 * (body == "B"), 0, 0])
        b.add_freejoint()
        b.add_geom(size=[0.03, 0, 0], contype=0, conaffinity=0)
    handle = mjflex.add_flexure(default, "link", "A", "B", pos=[0.1, 0, 0], K=K_DEMO)
    assert handle.plugin is not None and handle.text is None
    assert mjflex.Flexures(default.compile()).kinds == ("plugin",)
    record = mjflex.add_flexure(default, "second", "A", "B", pos=[0.1, 0, 0], K=K_DEMO, kind="record")
    assert record.text is not None and record.plugin is None
    assert mjflex.Flexures(default.compile()).kinds == ("record", "plugin")
    with pytest.raises(ValueError, match=r'kind must be "plugin" or "record"; got \'plugins\''):
        mjflex.add_flexure(default, "third", "A", "B", pos=[0.1, 0, 0], K=K_DEMO, kind="plugins")
    assert mjflex.Flexures(spec.compile()).kinds == ("plugin",)


def test_without_the_native_library_plugin_elements_are_refused_by_name(monkeypatch):
    """A broken install (no library): add_flexure refuses either form (the library checks a record too), naming the
    element and how to install it."""

    def missing():
        raise mjflex_plugin.NativeLibraryError("mjflex's native library is not built here (no C compiler)")

    spec = two_body_spec(B=B_DEMO)
    monkeypatch.setattr(_native, "_STATE", {})
    monkeypatch.setattr(mjflex_plugin, "library", missing)
    before = spec.to_xml()
    for kind in ("plugin", "record"):
        with pytest.raises(RuntimeError, match=r"flexure 'x': flexure elements need mjflex's native library, the "
                           r"engine plugin mjflex.flexure: .*no C compiler"):  # fmt: skip
            mjflex.add_flexure(spec, "x", "A", "B", pos=[0.1, 0.02, 0.5], K=K_DEMO, kind=kind)
    assert spec.to_xml() == before  # refused before anything was added
    with pytest.raises(RuntimeError, match=r"native library is not built here"):
        mjflex.Flexures(spec.compile())  # a text record's forces come from the same library


def test_remove_flexure_removes_plugin_elements_and_their_body_references():
    spec = two_body_spec(B=B_DEMO, kind="plugin")
    spec.body("B").plugin = spec.plugins[0]  # a body referencing the instance (MuJoCo computes it either way)
    mjflex.remove_flexure(spec, "link")
    model = spec.compile()
    assert model.nplugin == 0 and model.nsite == 0 and not spec.plugins
    with pytest.raises(ValueError, match=r"no flexure 'link' in the spec"):
        mjflex.remove_flexure(spec, "link")


def test_make_compliant_writes_a_plugin_element_and_make_rigid_takes_it_back():
    from tests.robots import arm_spec

    rigid = arm_spec().compile()
    spec = arm_spec()
    c = mjflex.make_compliant(spec, "hand", np.array([3e3, 5e3, 2e3, 1e8, 2e8, 3e8]), damping_ratio=0.01)
    model = spec.compile()
    assert mjflex.Flexures(model).kinds == ("plugin",) and model.ntext == 0
    mjflex.make_rigid(spec, c)
    back = spec.compile()
    assert back.nplugin == 0 and back.nsite == rigid.nsite and back.nq == rigid.nq
    assert np.array_equal(back.body_pos, rigid.body_pos)
    record = arm_spec()
    mjflex.make_compliant(record, "hand", [3e3, 5e3, 2e3, 1e8, 2e8, 3e8], kind="record")
    assert mjflex.Flexures(record.compile()).kinds == ("record",)


# ------------------------------------------------------------------ 2. the converter


def _tricky_record_spec():
    """Every record key, with numbers whose shortest text is 17 digits, tiny and huge magnitudes, JSON with unicode."""
    rng = np.random.default_rng(7)
    K = np.diag(rng.uniform(0.1, 10.0, 6) * [1, 1, 1, 1e6, 1e6, 1e6])
    K[0, 1] = K[1, 0] = 0.1 + 0.2  # 0.30000000000000004
    B = np.diag(rng.uniform(1e-9, 1e-7, 6))
    B[2, 2] = 5e-300
    # translational stiffness up to 1e7 N/m: the step is 1e-4 s (at 1e-3 s RK4 diverges in its fifth step)
    spec = two_body_spec(K=K, B=B, terms=polynomial_terms("twist"), timestep=1e-4)
    spec.delete(spec.text("mjflex:link"))
    source = {"E": 7e10, "note": "Π ≈ 3.14", "n": [1, 2**70]}
    record = schema.FlexureRecord("link", "twist", K, B, True, False, 1 / 3, source, polynomial_terms("twist"), 4,
                                  None, 0.0123)  # fmt: skip
    spec.add_text(name="mjflex:link", data=record.to_text())
    return spec


@pytest.mark.parametrize("case", ["tricky", "two_body.xml", "arcade.xml"])
def test_file_round_trip_is_lossless_and_steps_bit_identically(case, tmp_path):
    """record -> plugin -> record: identical records (every double, the source verbatim), the plugin form byte for
    byte on the second pass, and the compiled record and plugin models step bit-identically."""
    if case == "tricky":
        source = str(tmp_path / "tricky.xml")
        with open(source, "w") as f:
            f.write(_tricky_record_spec().to_xml())
    elif case == "arcade.xml":
        source = str(tmp_path / "arcade_records.xml")  # the committed model is in plugin form
        assert (
            mjflex.convert_file(ARCADE, source, to="record")
            and mjflex.Flexures(mujoco.MjModel.from_xml_path(source)).kinds == ("record",) * 48
        )
    else:
        source = TWO_BODY
    plugin, back, again = (str(tmp_path / n) for n in ("plugin.xml", "back.xml", "again.xml"))
    names = mjflex.convert_file(source, plugin, to="plugin")
    assert mjflex.convert_file(plugin, back, to="record") == names
    assert mjflex.convert_file(back, again, to="plugin") == names
    with open(plugin) as a, open(again) as b:
        assert a.read() == b.read()
    models = {k: mujoco.MjModel.from_xml_path(p) for k, p in (("record", source), ("plugin", plugin), ("back", back))}
    (flex, original), (pflex, converted), (_, returned) = (_records(models[k]) for k in ("record", "plugin", "back"))
    assert pflex.kinds == ("plugin",) * len(names) and flex.kinds == ("record",) * len(names)
    for name in names:
        assert same_record(original[name], converted[name]) and same_record(original[name], returned[name]), name
    with open(source) as f:
        original_text = f.read().replace(' sleep="never"', "")
    with open(back) as f:
        returned_text = f.read().replace(' sleep="never"', "")
    if case != "two_body.xml":  # files MuJoCo wrote: the round trip gives them back character for character
        assert returned_text == original_text
    key = 0 if models["record"].nkey else None
    qvel = None if key is not None else 0.2 * np.random.default_rng(2).normal(size=models["record"].nv)
    steps = 300 if case == "arcade.xml" else 1000
    with flex:
        expected = _trajectory(models["record"], qvel, steps, key)
    assert np.array_equal(_trajectory(models["plugin"], qvel, steps, key), expected)
    assert np.abs(expected[-1] - expected[0]).max() > 1e-5  # it moved


def test_spec_conversion_keeps_every_parameter_and_is_refused_when_there_is_nothing_to_do():
    spec = _tricky_record_spec()
    before = elements.element_record(spec, "link")
    assert mjflex.convert_model(spec, to="plugin") == ["link"]
    assert same_record(elements.element_record(spec, "link"), before)
    assert spec.body("A").sleep == spec.body("B").sleep == mujoco.mjtSleepPolicy.mjSLEEP_NEVER
    with pytest.raises(ValueError, match=r"already an mjflex\.flexure plugin instance; nothing to convert"):
        mjflex.convert_model(spec, to="plugin")
    assert mjflex.convert_model(spec, to="record") == ["link"]
    assert same_record(elements.element_record(spec, "link"), before)
    with pytest.raises(ValueError, match="already a text record"):
        mjflex.convert_model(spec, to="record")
    with pytest.raises(ValueError, match='to must be "plugin" or "record"'):
        mjflex.convert_model(spec, to="plugins")
    with pytest.raises(ValueError, match="holds no mjflex elements"):
        mjflex.convert_model(mujoco.MjSpec(), to="plugin")


def test_an_instance_whose_sites_a_record_cannot_find_is_named():
    spec = two_body_spec(kind="plugin")
    spec.site("link/a").name, spec.site("link/b").name = "left", "right"
    spec.plugins[0].config = {**dict(spec.plugins[0].config), "site_a": "left", "site_b": "right"}
    assert mjflex.Flexures(spec.compile()).names == ("link",)  # a plugin instance names its sites itself
    with pytest.raises(ValueError, match=r"flexure 'link': its sites are 'left' and 'right'.*rename the sites"):
        mjflex.convert_model(spec, to="record")
    assert len(spec.plugins) == 1  # nothing changed


def _cli(args, capsys):
    try:
        cli.main(args)
    except SystemExit as exc:
        err = capsys.readouterr().err + (str(exc.code) if isinstance(exc.code, str) else "")
        return (1 if isinstance(exc.code, str) else exc.code), err
    return 0, capsys.readouterr().out


def test_convert_command_and_its_one_line_errors(tmp_path, capsys):
    out = str(tmp_path / "plugin.xml")
    code, text = _cli(["convert", TWO_BODY, out], capsys)
    assert code == 0 and text.strip() == f"wrote {out}: 1 element(s) as mjflex.flexure plugin instances: hinge"
    not_xml, other_root, empty = tmp_path / "x.xml", tmp_path / "y.xml", tmp_path / "z.xml"
    not_xml.write_text("{not xml")
    other_root.write_text("<robot/>")
    empty.write_text("<mujoco><worldbody/></mujoco>")
    cases = [
        ([str(not_xml), out], "is not an MJCF file: it is not well-formed XML"),
        ([str(other_root), out], "is not an MJCF file: its root element is <robot>, not <mujoco>"),
        ([str(empty), out], "holds no mjflex elements"),
        ([out, str(tmp_path / "p2.xml")], "is already an mjflex.flexure plugin instance; nothing to convert"),
        ([TWO_BODY, str(tmp_path / "b.xml"), "--to", "record"], "is already a text record; nothing to convert"),
        ([TWO_BODY, str(tmp_path / "no" / "such.xml")], "the folder"),
        ([TWO_BODY, str(tmp_path)], "is a folder; give a file name"),
        ([str(tmp_path / "missing.xml"), out], "not found"),
    ]
    for args, message in cases:
        code, err = _cli(["convert", *args], capsys)
        lines = [line for line in err.splitlines() if line.strip()]
        assert code == 1 and len(lines) == 1 and message in lines[0] and lines[0].startswith("error: "), (args, err)
    assert not (tmp_path / "p2.xml").exists() and not (tmp_path / "b.xml").exists()


def test_committed_plugin_twin_is_the_converters_output(tmp_path):
    """models/two_body.xml stays the hand-written text-record example; two_body_plugin.xml is its converted twin."""
    out = str(tmp_path / "twin.xml")
    mjflex.convert_file(TWO_BODY, out, to="plugin")
    with open(out) as a, open(os.path.join(MODELS, "two_body_plugin.xml")) as b:
        assert a.read() == b.read(), "run: python -m mjflex convert models/two_body.xml models/two_body_plugin.xml"


# ------------------------------------------------------------------ 3. the committed models without mjflex


RUN_WITHOUT_MJFLEX = r"""
import sys, numpy as np, mujoco
from mujoco import rollout
from mujoco.batch import Batch
model = mujoco.MjModel.from_xml_path(sys.argv[1])
key, steps = 0, 200
def serial(q):
    d = mujoco.MjData(model); mujoco.mj_resetDataKeyframe(model, d, key); d.qvel[:] += q
    for _ in range(steps): mujoco.mj_step(model, d)
    return d.qpos.copy(), d
qs = [np.zeros(model.nv), 0.1 * np.random.default_rng(1).normal(size=model.nv)]
ref = [serial(q) for q in qs]
kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
states = []
for q in qs:
    d = mujoco.MjData(model); mujoco.mj_resetDataKeyframe(model, d, key); d.qvel[:] += q
    s = np.empty(mujoco.mj_stateSize(model, kind)); mujoco.mj_getState(model, d, s, kind); states.append(s)
out, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], np.array(states), nstep=steps)
batch = Batch(model, nsim=2, nthread=2)
batch.qpos = np.array([model.key_qpos[key]] * 2); batch.qvel = np.array([model.key_qvel[key] + q for q in qs])
batch.step(nstep=steps)
names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i) for i in range(model.nsite)]
pairs = [(i, names.index(n[:-1] + "b")) for i, n in enumerate(names) if n.endswith("/a")]
gap = max(float(np.linalg.norm(ref[0][1].site_xpos[a] - ref[0][1].site_xpos[b])) for a, b in pairs)
print(dict(rollout=bool(np.array_equal(out[:, -1, 1:1 + model.nq], np.array([r[0] for r in ref]))),
           batch=bool(np.array_equal(batch.qpos, np.array([r[0] for r in ref]))), gap=gap, elements=len(pairs),
           mjflex="mjflex" in sys.modules))
"""


@pytest.mark.parametrize("name", ["arcade.xml", "arcade_rigid.xml"])
def test_committed_arcade_runs_in_rollout_and_batch_without_mjflex(name):
    """`import mujoco` alone: the paper run in mujoco.rollout (2 threads) and Batch equals the serial loop bit for bit
    and the guide holds together (without the elements' forces the bodies leave at metres per second)."""
    done = subprocess.run([sys.executable, "-c", RUN_WITHOUT_MJFLEX, os.path.join(MODELS, name)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    got = eval(done.stdout.strip().splitlines()[-1])  # our own printed dict
    assert got["rollout"] and got["batch"] and got["elements"] == 48 and not got["mjflex"]
    assert got["gap"] < 2e-3  # 2 ms of the paper run: sites stay within the elements' deflection


# ------------------------------------------------------------------ 7. sleeping


def test_plugin_trees_stay_awake_and_move_exactly_as_without_sleep():
    """The plugin cannot change the model: add_flexure wrote sleep="never" on the joined trees, so with sleeping
    enabled a push of A drags B exactly as with sleeping disabled, momentum shared."""
    awake = push_after_rest(two_body_spec(B=B_DEMO, integrator="Euler", kind="plugin").compile(), provider=False)
    spec = two_body_spec(B=B_DEMO, integrator="Euler", kind="plugin")
    assert spec.body("A").sleep == spec.body("B").sleep == mujoco.mjtSleepPolicy.mjSLEEP_NEVER
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    got = push_after_rest(spec.compile(), provider=False)  # no mjflex in the loop: the file alone keeps them awake
    assert np.array_equal(got, awake) and np.abs(got[-1, 6:9]).max() > 0.1
    linear = got[:, 0:3] * 1.3 + got[:, 6:9] * 0.8
    assert np.allclose(linear, linear[0], rtol=0, atol=1e-12 * np.abs(linear[0]).max())
    # without sleep="never" the trees fall asleep and B never learns of the push
    for body in ("A", "B"):
        spec.body(body).sleep = mujoco.mjtSleepPolicy.mjSLEEP_AUTO
    asleep = push_after_rest(spec.compile(), provider=False)
    assert not np.array_equal(asleep, awake)


def test_the_plugin_warns_when_a_joined_tree_may_sleep(capfd):
    spec = two_body_spec(B=B_DEMO, integrator="Euler", kind="plugin")
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    mujoco.MjData(spec.compile())
    assert "may sleep" not in capfd.readouterr().err
    spec.body("B").sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    model = spec.compile()
    capfd.readouterr()
    mujoco.MjData(model)
    err = capfd.readouterr().err
    assert "mjflex: flexure 'link' (and 0 more) joins the tree of body 'B', which may sleep" in err
    assert 'Set sleep="never" on that body' in err
    model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    mujoco.MjData(model)
    assert "may sleep" not in capfd.readouterr().err  # sleeping disabled: nothing to lose


def test_converting_writes_sleep_never_and_keeps_an_explicit_choice_with_a_warning(tmp_path):
    path, out = tmp_path / "m.xml", tmp_path / "p.xml"
    spec = two_body_spec(B=B_DEMO)
    spec.body("B").sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    path.write_text(spec.to_xml())
    with pytest.warns(UserWarning, match=r"flexure 'link' joins the tree of body 'B', whose sleep policy 'allowed'"):
        mjflex.convert_file(str(path), str(out), to="plugin")
    model = mujoco.MjModel.from_xml_path(str(out))
    assert [mujoco.mjtSleepPolicy(p).name for p in model.tree_sleep_policy] == ["mjSLEEP_NEVER", "mjSLEEP_ALLOWED"]


# ------------------------------------------------------------------ 8. composed models


def test_attach_with_prefix_and_suffix_and_two_copies_of_one_child():
    """MjSpec.attach (and copy) drop plugin instances no body references; mjflex.attach / copy_spec keep them, and
    each copy moves as the model alone."""
    child = two_body_spec(B=B_DEMO, kind="plugin")
    alone = child.compile()
    lost = mujoco.MjSpec()
    lost.option.gravity = [0, 0, 0]
    lost.option.timestep, lost.option.integrator = alone.opt.timestep, alone.opt.integrator
    lost.attach(mjflex.copy_spec(child), prefix="r-", frame=lost.worldbody.add_frame())
    assert lost.compile().nplugin == 0 and len(child.copy().plugins) == 0  # MuJoCo 4.0's behaviour
    with pytest.warns(UserWarning, match=r"sites of an element 'r-link'.*mjflex.attach / mjflex.copy_spec"):
        mjflex.Flexures(lost.compile())
    parent = mujoco.MjSpec()
    parent.option.gravity = [0, 0, 0]
    parent.option.timestep, parent.option.integrator = alone.opt.timestep, alone.opt.integrator
    for prefix, suffix in [("robot1-", ""), ("robot2-", "-r"), ("arm/", "")]:
        mjflex.attach(parent, mjflex.copy_spec(child), prefix=prefix, suffix=suffix, frame=parent.worldbody.add_frame())
    model = parent.compile()
    flex = mjflex.Flexures(model)
    assert flex.names == ("robot1-link", "robot2-link-r", "arm/link") and set(flex.kinds) == {"plugin"}
    assert [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, int(s)) for s in flex.site_ids[1]] == [
        "robot2-link/a-r", "robot2-link/b-r"]  # fmt: skip
    data, ref = mujoco.MjData(model), mujoco.MjData(alone)
    ref.qvel[:] = np.random.default_rng(0).normal(size=alone.nv)
    data.qvel[:] = np.tile(ref.qvel, 3)
    for _ in range(300):
        mujoco.mj_step(model, data)
        mujoco.mj_step(alone, ref)
    for robot in range(3):
        assert np.array_equal(data.qpos[14 * robot : 14 * robot + 14], ref.qpos)
    assert np.abs(ref.qpos - alone.qpos0).max() > 1e-3


def test_an_attached_frame_site_is_found_under_the_prefix():
    """add_flexure(site=...) stores the frame site; mjflex.attach renames it with the sites (prefix + site + suffix),
    and the plugin finds it (a configuration attached by mjflex 1.0, unprefixed: tests/test_schema.py)."""
    from tests.robots import K_HAND, arm_spec

    arm = arm_spec()
    arm.body("hand").add_joint(type=mujoco.mjtJoint.mjJNT_BALL, limited=mujoco.mjtLimited.mjLIMITED_FALSE)
    for key in arm.keys:
        key.qpos = [*key.qpos, 1, 0, 0, 0]
    mjflex.add_flexure(arm, "wrist", "link3", "hand", site="wrist", K=K_HAND)
    arm.add_exclude(bodyname1="hand", bodyname2="link2")
    scene = mujoco.MjSpec()
    mjflex.attach(scene, arm, prefix="r-", suffix="-1", frame=scene.worldbody.add_frame())
    with pytest.warns(UserWarning):  # contacts of the arm's neighbours: not this test's subject
        flex = mjflex.Flexures(scene.compile())
    assert flex.names == ("r-wrist-1",) and flex.records[0].site == "r-wrist-1"


# ------------------------------------------------------------------ 6. the command line, the study, the sweep


def test_simulate_method_and_no_damping_on_a_plugin_model(tmp_path, capsys):
    plugin = os.path.join(MODELS, "two_body_plugin.xml")
    summaries = {}
    for name, path, extra in [("record", TWO_BODY, []), ("plugin", plugin, []),
                              ("plugin-dq", plugin, ["--method", "dualquat", "--no-damping"]),
                              ("record-dq", TWO_BODY, ["--method", "dualquat", "--no-damping"])]:  # fmt: skip
        out = tmp_path / f"{name}.json"
        code, text = _cli(["simulate", path, "--duration", "0.004", "--quiet", "--json", str(out), *extra], capsys)
        assert code == 0, text
        summaries[name] = json.loads(out.read_text())
    assert summaries["plugin"]["method"] == "twist" and summaries["plugin-dq"]["method"] == "dualquat"
    assert summaries["plugin-dq"]["dissipated"] == 0.0 and summaries["plugin"]["dissipated"] > 0.0
    for a, b in (("record", "plugin"), ("record-dq", "plugin-dq")):  # the same motion either way
        for key in ("energy_end", "max_rotation", "dissipated"):
            assert summaries[a][key] == summaries[b][key], (a, key)
    model = mujoco.MjModel.from_xml_path(plugin)
    with pytest.raises(SystemExit, match=r"flexure 'hinge' is an mjflex.flexure plugin instance.*mjflex.edit_elements"):
        runs.run_model(model, "two_body_plugin.xml", duration=0.001, method="dualquat", progress=False)


def test_study_switches_the_method_of_plugin_elements_by_compiling_copies():
    """The study of the plugin twin measures exactly what the study of the text-record file does: the dualquat rows
    come from a model compiled with method="dualquat" (the plugin's own method), not from a run-time switch."""
    options = dict(methods=("twist", "dualquat"), integrators=("rk4",), steps=[2e-5], duration=0.002, bisect=0,
                   repeat=1, variants=[], progress=False, samples=20)  # fmt: skip
    results = {p: mjflex.study(os.path.join(MODELS, p), **options) for p in ("two_body.xml", "two_body_plugin.xml")}
    rows = {p: {(r.method, r.integrator): r for r in res.rows if r.source == "grid"} for p, res in results.items()}
    assert set(rows["two_body_plugin.xml"]) == {("twist", "rk4"), ("dualquat", "rk4")}
    for key, row in rows["two_body.xml"].items():
        other = rows["two_body_plugin.xml"][key]
        assert (row.status, row.pose_error, row.energy_error) == (other.status, other.pose_error, other.energy_error)
    assert (
        rows["two_body_plugin.xml"]["twist", "rk4"].pose_error
        != rows["two_body_plugin.xml"]["dualquat", "rk4"].pose_error
    )
    model = mujoco.MjModel.from_xml_path(os.path.join(MODELS, "two_body_plugin.xml"))
    mujoco.MjModel.from_xml_path(TWO_BODY)  # MuJoCo keeps only the last model's XML
    with pytest.raises(mjflex.app.study.StudyError, match=r"whose method is part of the model.*pass the file's path"):
        mjflex.study(model, **options)


def test_sweep_edits_plugin_elements_in_their_own_form():
    from mjflex.app.sweep import edit_flexure, flexure_matrices

    spec = mujoco.MjSpec.from_file(os.path.join(MODELS, "two_body_plugin.xml"))
    K, _ = flexure_matrices(spec, "hinge")
    edit_flexure(spec, "hinge", K=2 * K, B=[])
    K2, B2 = flexure_matrices(spec, "hinge")
    assert np.array_equal(K2, 2 * K) and B2 is None and len(spec.plugins) == 1 and not spec.texts
    flex = mjflex.Flexures(spec.compile())
    assert flex.kinds == ("plugin",) and np.array_equal(flex.records[0].K, 2 * K)
    with pytest.raises(ValueError, match=r"flexure 'hinge'.*not positive semi-definite"):
        edit_flexure(spec, "hinge", K=-K)
    with pytest.raises(KeyError, match=r"no flexure 'hing'.*did you mean \['hinge'\]"):
        flexure_matrices(spec, "hing")


# ------------------------------------------------------------------ 6. variants keep the form of their input


def test_reduce_and_the_native_variants_keep_plugin_elements_plugins():
    from mjflex.app.scenes import parallelogram_spec

    plugin = parallelogram_spec()
    record = as_records(plugin)
    variants = {}
    for form, spec in (("plugin", plugin), ("record", record)):
        variants[form] = mjflex.reduce(spec, 100.0, loops="element", verify=False)
    p, r = variants["plugin"], variants["record"]
    assert p.has_flexures and p.model.ntext == 0 and p.model.nplugin > 0
    assert r.model.nplugin == 0 and r.model.ntext > 0
    pflex, rflex = mjflex.Flexures(p.model), mjflex.Flexures(r.model)
    assert pflex.names == rflex.names and set(pflex.kinds) == {"plugin"}
    assert all(same_record(a, b) for a, b in zip(pflex.records, rflex.records, strict=True))
    qvel = 0.1 * np.random.default_rng(4).normal(size=p.model.nv)
    with rflex:
        expected = _trajectory(r.model, qvel, 300)
    assert np.array_equal(_trajectory(p.model, qvel, 300), expected)
    weld = mjflex.weld_variant(plugin)
    assert (
        not weld.has_flexures and weld.model.nplugin == 0 and weld.model.neq == len(mjflex.Flexures(plugin.compile()))
    )


# ------------------------------------------------------------------ 6. analyses on plugin models


def test_normal_modes_and_table_agree_on_both_forms():
    record = two_body_spec(B=B_DEMO, terms=polynomial_terms("twist"))
    models = {"record": record.compile(), "plugin": as_plugins(record).compile()}
    flexes = {k: mjflex.Flexures(m) for k, m in models.items()}
    modes = {k: mjflex.normal_modes(models[k], flexes[k]) for k in models}
    assert np.array_equal(modes["record"][0], modes["plugin"][0]) and modes["record"][0][-1] > 1.0
    datas = {k: mujoco.MjData(m) for k, m in models.items()}
    for k, d in datas.items():
        d.qpos[7:10] += [0.01, -0.02, 0.005]
        d.qvel[:] = 0.3
        mujoco.mj_forward(models[k], d)
    tables = {k: flexes[k].results(datas[k]) for k in models}
    for field in ("wrench", "displacement", "energy", "power"):
        assert np.array_equal(tables["record"][field], tables["plugin"][field]), field
    assert copy.copy(flexes["plugin"]).kinds == ("plugin",)
