"""The engine plugin through every life of an MjData that MuJoCo's public API allows (issue 22).

Each case runs in a child process (tests/native_cases.run_python): a crash, a hang or a sanitizer
report fails that test, not the suite. In every case the forces are checked against a data made from
the model it is stepped with (bit for bit: the same elements go through the same C loop), and the
plugin's registry is checked to hold nothing once the datas are gone (``mjfx_live_instances``,
``mjfx_states_count``).

Items of the issue: 1 (rollout with a model list of other element counts), 2 (pickled MjData, in this
and in another process), 3 (mocap bodies at load), 5 (a failed read of another model's elements), and
the plugin_data words the plugin must never trust (item 9's leader_for).
"""

import pytest

from tests.native_cases import run_python

PRELUDE = """
import copy, ctypes, gc, pickle
import numpy as np
import mujoco
import mjflex_plugin
from tests.native_cases import two_body_xml, plain_xml, chain_xml
lib = mjflex_plugin.library()
lib.mjfx_live_instances.restype = lib.mjfx_states_count.restype = ctypes.c_long
BASE = (lib.mjfx_live_instances(), lib.mjfx_states_count())

def model(xml):
    return mujoco.MjModel.from_xml_string(xml)

def moving(m, seed=0):
    d = mujoco.MjData(m)
    d.qvel[:] = 0.3 * np.random.default_rng(seed).normal(size=m.nv)
    if m.nmocap:
        d.mocap_pos[0] += [0.002, -0.001, 0.003]
    mujoco.mj_forward(m, d)
    return d

def own_forces(m, other):
    # qfrc_passive of a data made from m, in the state of `other`
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = other.qpos, other.qvel
    d.mocap_pos[:], d.mocap_quat[:] = other.mocap_pos, other.mocap_quat
    mujoco.mj_forward(m, d)
    return d.qfrc_passive.copy()

def serial(m, d0, nstep):
    d = copy.copy(d0)
    mujoco.mj_step(m, d, nstep)
    return np.r_[d.qpos, d.qvel]

def nothing_left():
    for name in [k for k, v in globals().items() if isinstance(v, mujoco.MjData)]:
        del globals()[name]
    gc.collect()
    now = (lib.mjfx_live_instances(), lib.mjfx_states_count())
    assert now == BASE, f"the plugin holds {now} (elements, states), {BASE} before"
"""


def _run(body, **kwargs):
    return run_python(PRELUDE + body + "\nnothing_left()\nprint('done')\n", **kwargs)


def test_rollout_with_a_model_list_of_more_and_fewer_elements():
    """Item 1: rollout steps a data with any model of equal nv: datas made from a 1-element model stepped with a
    12-element one and back (and the reverse), in 2 threads; each rollout moves as its own model's data does."""
    _run("""
from mujoco import rollout
base, variant = model(two_body_xml(1)), model(two_body_xml(12))
assert (base.nplugin, variant.nplugin) == (1, 12) and base.nv == variant.nv
kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
states = []
for seed in range(3):
    d = moving(base, seed)
    s = np.empty(mujoco.mj_stateSize(base, kind))
    mujoco.mj_getState(base, d, s, kind)
    states.append(s)
models = [base, variant, base]
for made_from in (base, variant):
    datas = [mujoco.MjData(made_from) for _ in range(2)]
    out, _ = rollout.rollout(models, datas, np.array(states), nstep=40)
    for i, m in enumerate(models):
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, states[i], kind)
        mujoco.mj_step(m, d, 40)
        assert np.array_equal(out[i, -1, 1:1 + m.nq], d.qpos), (made_from.nplugin, i)
    assert not np.array_equal(out[0, -1], out[1, -1])  # the 12 elements are stiffer: the variant moved otherwise
    del datas
""")


def test_a_pickled_data_in_this_process():
    """Item 2: MjData.__setstate__ overwrites plugin_data with the source's pointers; the source is stepped, freed,
    and the copy goes on as a copy made by copy.copy does."""
    _run("""
m = model(two_body_xml(3))
d = moving(m)
mujoco.mj_step(m, d, 5)
twin = pickle.loads(pickle.dumps(d))
expected = serial(m, d, 50)
mujoco.mj_step(m, d, 7)  # the source moves on with its own state
assert np.array_equal(serial(m, twin, 50), expected)
del d
gc.collect()  # the source's instances are gone; the copy's words still point at them
mujoco.mj_step(m, twin, 50)
assert np.array_equal(np.r_[twin.qpos, twin.qvel], expected)
mujoco.mj_resetData(m, twin)
mujoco.mj_step(m, twin, 3)
assert np.all(np.isfinite(twin.qfrc_passive))
twin2 = pickle.loads(pickle.dumps(twin))
del twin, twin2
""")


def test_a_pickled_data_in_another_process():
    """Item 2: in another process (multiprocessing, Dask) the pickled words are another address space's."""
    _run(
        """
import concurrent.futures, multiprocessing
from tests.native_cases import step_pickled
m = model(two_body_xml(2))
d = moving(m)
mujoco.mj_step(m, d, 5)
ctx = multiprocessing.get_context("spawn")
with concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx) as pool:
    there = pool.submit(step_pickled, pickle.dumps((m, d)), 40).result(timeout=120)
assert np.array_equal(there, serial(m, d, 40))
del d
""",
        timeout=240,
    )


def test_mj_copydata_across_models_with_more_and_fewer_elements():
    """mj_copyData(dest, m, src) lays dest out for m (when the buffers are of one size, as here for 1 and 2
    elements): dest then holds the source's words past its own; it moves as m's data, and nothing is freed twice.
    Where the sizes differ MuJoCo refuses with an error (no crash)."""
    _run("""
small, big = model(two_body_xml(1)), model(two_body_xml(2))
for dest_model, src_model in ((small, big), (big, small)):
    dest, src = mujoco.MjData(dest_model), moving(src_model)
    mujoco.mj_copyData(dest, src_model, src)
    mujoco.mj_forward(src_model, dest)
    assert np.array_equal(dest.qfrc_passive, own_forces(src_model, src))
    assert np.array_equal(serial(src_model, dest, 30), serial(src_model, src, 30))
    del dest, src
gc.collect()
huge = model(two_body_xml(9))
dest, src = mujoco.MjData(small), moving(huge)
try:
    mujoco.mj_copyData(dest, huge, src)
except Exception as exc:
    assert "different size" in str(exc), exc
else:
    mujoco.mj_forward(huge, dest)
    assert np.array_equal(dest.qfrc_passive, own_forces(huge, src))
del dest, src
""")


def test_copies_keep_their_own_elements():
    """copy.copy, copy.deepcopy and mj_copyData(None, ...): the plugin's init and copy run for each."""
    _run("""
m = model(two_body_xml(2))
d = moving(m)
mujoco.mj_step(m, d, 3)
expected = serial(m, d, 40)
for twin in (copy.copy(d), copy.deepcopy(d)):
    mujoco.mj_step(m, twin, 40)
    assert np.array_equal(np.r_[twin.qpos, twin.qvel], expected)
assert lib.mjfx_states_count() == BASE[1] + 2  # d and the last twin
del twin
""")


def test_one_data_stepped_with_two_models_in_turn():
    """Two model objects interleaved on one data (other element counts; other stiffness; a copy with another rest
    offset): each step reads its model's elements."""
    _run("""
shifted = model(two_body_xml(2))
moved = copy.copy(shifted)
moved.site_pos[1] += [1e-6, 0, 0]  # a copy: the same sizes and text, another rest offset (within tolerance)
pairs = ((model(two_body_xml(1)), model(two_body_xml(3))), (model(two_body_xml(2)), model(two_body_xml(2, scale=3.0))),
         (shifted, moved))
for soft, stiff in pairs:
    d = moving(soft)
    for k in range(6):
        m = (soft, stiff)[k % 2]
        expected = own_forces(m, d)
        mujoco.mj_forward(m, d)
        assert np.array_equal(d.qfrc_passive, expected), k
        mujoco.mj_step(m, d)
""")


def test_a_failed_read_of_another_model_does_not_break_the_data():
    """Item 5: stepped once with a copy whose sites no longer meet, the data gets NaN forces (and a warning) with
    that copy only; back on its own model, and after mj_resetData, its forces are right again."""
    result = _run("""
m = model(two_body_xml(1))
apart = copy.copy(m)
apart.site_pos[1] += [0.05, 0, 0]
d = moving(m)
good = d.qfrc_passive.copy()
mujoco.mj_forward(apart, d)
assert np.all(np.isnan(d.qfrc_passive))
mujoco.mj_forward(apart, d)  # refused again, said once
mujoco.mj_forward(m, d)
assert np.array_equal(d.qfrc_passive, good)
mujoco.mj_resetData(m, d)
mujoco.mj_forward(m, d)
assert np.array_equal(d.qfrc_passive, own_forces(m, d)) and np.all(np.isfinite(d.qfrc_passive))
""")
    out = result.stdout + result.stderr
    assert out.count("cannot be read: its forces are NaN with that model") == 1, out
    assert "sites 'a' and 'b' are 0.0" in out


def test_words_in_plugin_data_are_never_trusted():
    """Item 9 (leader_for cast plugin_data to an instance): whatever the words hold, the plugin uses its own."""
    _run("""
m = model(two_body_xml(2))
d = moving(m)
expected = d.qfrc_passive.copy()
for garbage in (0, 1, 12345, 2**63 + 8, int(d.plugin_data[0]) + 8):
    d.plugin_data[:] = garbage
    mujoco.mj_forward(m, d)
    assert np.array_equal(d.qfrc_passive, expected)
    d.plugin_data[:] = garbage
    mujoco.mj_resetData(m, d)  # MuJoCo passes the words to reset
    d.qvel[:] = moving(m).qvel
    mujoco.mj_forward(m, d)
d2 = moving(m)
d2.plugin_data[:] = d.plugin_data  # another live data's words
mujoco.mj_resetData(m, d2)
d2.qvel[:] = d.qvel
mujoco.mj_forward(m, d2)
assert np.array_equal(d2.qfrc_passive, expected)
""")


def test_mocap_bodies_load_every_time():
    """Item 3: init ran mj_kinematics on the unreset data (mocap poses uninitialized): of 30 loads some failed.
    MALLOC_PERTURB_ fills new memory with a pattern, so the old code fails every time."""
    for perturb in ("85", "170"):
        _run(
            """
for _ in range(30):
    m = model(two_body_xml(1, mocap=True))
    d = moving(m)
    assert np.array_equal(d.qfrc_passive, own_forces(m, d))
    assert np.abs(d.qfrc_passive).max() > 0  # the mocap body moved: the element pulls
""",
            env={"MALLOC_PERTURB_": perturb},
        )


def test_recompile_and_attach():
    """MjSpec.recompile remakes model and data in place; MjSpec.attach prefixes every name (the sites a
    configuration names are found under the prefix): two copies of a child move as the child alone."""
    _run("""
spec = mujoco.MjSpec.from_string(two_body_xml(2))
m = spec.compile()
d = moving(m)
mujoco.mj_step(m, d, 3)
spec.body("B").mass = 1.1
m2, d2 = spec.recompile(m, d)
assert np.array_equal(d2.qpos, d.qpos)
mujoco.mj_forward(m2, d2)
assert np.array_equal(d2.qfrc_passive, own_forces(m2, d2))
child = two_body_xml(1, attached=True)
parent = mujoco.MjSpec()
parent.option.gravity = [0, 0, 0]
for prefix in ("left-", "right-"):
    parent.attach(mujoco.MjSpec.from_string(child), prefix=prefix, frame=parent.worldbody.add_frame())
both, alone = parent.compile(), model(child)
assert both.nplugin == 2
d3, ref = mujoco.MjData(both), moving(alone)
d3.qvel[:] = np.tile(ref.qvel, 2)
mujoco.mj_step(both, d3, 30)
mujoco.mj_step(alone, ref, 30)
for robot in range(2):
    assert np.array_equal(d3.qpos[14 * robot:14 * robot + 14], ref.qpos)
del d, d2, d3, ref
""")


def test_sleeping_trees_and_a_data_without_elements():
    """Sleeping enabled: the plugin warns that a joined tree may sleep, and stepping through sleep and wake-up
    stays finite. A data made from a model without elements (no state of its own can live in it) stepped with a
    model that has them gets the right forces, read at every step (said once)."""
    result = _run("""
m = model(two_body_xml(1, sleep=True))
d = moving(m)
for _ in range(400):
    mujoco.mj_step(m, d)
assert np.all(np.isfinite(d.qpos))
plain, flexed = model(plain_xml()), model(two_body_xml(2))
assert plain.nplugin == 0 and plain.nv == flexed.nv
d = mujoco.MjData(plain)
d.qvel[:] = 0.2
for _ in range(3):
    expected = own_forces(flexed, d)
    mujoco.mj_forward(flexed, d)
    assert np.array_equal(d.qfrc_passive, expected)
    mujoco.mj_step(flexed, d)
del d
""")
    out = result.stdout + result.stderr
    assert "which may sleep" in out
    assert out.count("its elements are read again at every step (slow)") == 1


def test_a_second_copy_of_the_library():
    """A copy of the library loaded from another path (another install, ctypes.CDLL) must not end the process:
    MuJoCo makes registering a different plugin under the same name a fatal error. The copy stays unregistered,
    says so, and the first copy keeps serving the plugin models."""
    result = _run("""
import os, shutil, tempfile
folder = tempfile.mkdtemp()
copy_path = os.path.join(folder, os.path.basename(mjflex_plugin.library_path()))
shutil.copy(mjflex_plugin.library_path(), copy_path)
other = ctypes.CDLL(copy_path)
assert other.mjfx_status() == -2 and lib.mjfx_status() == 1
mujoco.mj_loadPluginLibrary(copy_path)  # the same through MuJoCo's loader
m = model(two_body_xml(2))
d = moving(m)
assert np.abs(d.qfrc_passive).max() > 0 and np.array_equal(d.qfrc_passive, own_forces(m, d))
del d
state = dict(mjflex_plugin._STATE)
mjflex_plugin._STATE.clear()  # as a second installation of mjflex would find it
os.environ["MJFLEX_NATIVE_DIR"] = folder
try:
    mjflex_plugin.library()
except mjflex_plugin.NativeLibraryError as exc:
    assert "another copy of mjflex's native library" in str(exc) and "two installations" in str(exc), exc
else:
    raise AssertionError("the copy was taken for the plugin")
mjflex_plugin._STATE.clear()
mjflex_plugin._STATE.update(state)
""")
    assert result.returncode == 0


def test_chain_elements_on_a_data_of_another_chain_model():
    """Elements on dof chains (hinge, slide, ball, a jointless body) read again for a copy of the model."""
    _run("""
m = model(chain_xml(4))
stiff = copy.copy(m)
d = moving(m)
d.qpos[:] += 0.05 * np.random.default_rng(1).normal(size=m.nq)
mujoco.mj_forward(m, d)
assert np.abs(d.qfrc_passive).max() > 0
mujoco.mj_forward(stiff, d)
assert np.array_equal(d.qfrc_passive, own_forces(stiff, d))
""")


@pytest.mark.parametrize("threads", [1, 4])
def test_make_and_free_datas_in_threads(threads):
    """The registry under concurrent make, step and free of datas (6 models' worth, in threads)."""
    _run(f"""
import threading
models = [model(two_body_xml(n)) for n in (1, 2, 3)]
errors = []

def work(k):
    try:
        for r in range(30):
            m = models[(k + r) % 3]
            d = moving(m, r)
            mujoco.mj_step(m, d, 2)
            twin = copy.copy(d)
            mujoco.mj_step(models[(k + r + 1) % 3], twin, 2)
            del d, twin
    except Exception as exc:
        errors.append(exc)

ts = [threading.Thread(target=work, args=(k,)) for k in range({threads})]
[t.start() for t in ts]
[t.join() for t in ts]
assert not errors, errors
""")


def test_the_known_issues_page_still_reproduces_mujocos_double_free():
    """docs/background/known_issues.md reports MuJoCo's pickle bug with a reproducer that needs no mjflex (MuJoCo's own
    PID plugin): it must still abort with a double free, or MuJoCo fixed it and the page must say so."""
    import os
    import re

    from tests.native_cases import ROOT

    with open(os.path.join(ROOT, "docs", "background", "known_issues.md"), encoding="utf-8") as f:
        blocks = re.findall(r"```python\n(.*?)```", f.read(), re.S)
    result = run_python(blocks[0], check=False, timeout=120)
    out = result.stdout + result.stderr
    assert result.returncode != 0 and re.search(r"double[ -]free", out), (
        f"the reproducer of MuJoCo's pickle bug exited with {result.returncode}: if MuJoCo fixed it, update "
        f"docs/background/known_issues.md\n{out[-3000:]}"
    )
