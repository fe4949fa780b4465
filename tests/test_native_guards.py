"""Guards that bugs planted by an audit broke without a test noticing (issue 33 item 17).

Each test here fails when its guard is broken: the stop check lower <= upper on every coordinate (the last one
too), in every place it lives; a freed per-data state taken off the registry's live set; the registry's
generation check (a data freed without MuJoCo calling destroy, then a new data at the same address); a copied data
carrying on its source's divergence tallies; and the dof-chain buffer at its fullest (this file runs under
AddressSanitizer, tests/test_native_sanitizers.py, where an overflow of it is a report, not luck).
"""

import copy
import ctypes
import gc
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.core import stops as core_stops
from mjflex.native import library
from tests.native_cases import K_DIAG

SPATIAL, PLANAR = ("rx", "ry", "rz", "x", "y", "z"), ("theta", "x", "y")
#: Elements in parallel with joints on purpose here (the planar bodies' joints, the chain's hinges).
pytestmark = pytest.mark.filterwarnings("ignore:flexure '.*' joins .* already join:mjflex.LikelyMistakeWarning")


def _bodies(n=1, planar=False):
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    for i in range(n):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.1 * (i + 1), 0, 0], mass=0.2, inertia=[2e-4] * 3)
        body.explicitinertial = True
        if planar:
            for j, axis in (("x", [1, 0, 0]), ("y", [0, 1, 0])):
                body.add_joint(name=f"{j}{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
            body.add_joint(name=f"t{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        else:
            body.add_freejoint()
    return spec


def _crossed(n, i):
    """Limits with lower above upper on coordinate ``i`` only (of ``n``)."""
    lower, upper = [None] * n, [None] * n
    lower[i], upper[i] = 0.02, 0.01
    return lower, upper


@pytest.mark.parametrize(("n", "i"), [(6, i) for i in range(6)] + [(3, i) for i in range(3)])
def test_lower_above_upper_is_refused_on_every_coordinate_in_every_form(n, i):
    """The last coordinate (z; planar y) too: a loop that stops one short passed every test in 1.0.0. Checked by
    mjflex.Stops, the core's stop functions, a text record's stops and a plugin instance's configuration (C)."""
    name = (SPATIAL if n == 6 else PLANAR)[i]
    lower, upper = _crossed(n, i)
    crossed = rf"lower of {name} \(0.02\) is above (its )?\S*upper \(0.01\)"  # one check's words in every form
    with pytest.raises(ValueError, match=crossed):
        mjflex.Stops(lower=lower, upper=upper)
    lo = np.where(np.equal(lower, None), -np.inf, lower).astype(float)
    hi = np.where(np.equal(upper, None), np.inf, upper).astype(float)
    with pytest.raises(ValueError, match="lower > upper"):
        if n == 6:
            core_stops.stop_potential(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), lo, hi, np.ones(6))
        else:
            core_stops.planar_stop_potential(0.0, np.zeros(2), 0.0, np.zeros(2), lo, hi, np.ones(3))
    K = [1.0] * n if n == 6 else [1.0, 1e3, 1e3]
    spec = _bodies(planar=n == 3)
    handle = mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=K, kind="record")
    text = spec.text("mjflex:disc")
    limits = (
        ", ".join("null" if v is None else repr(v) for v in lower),
        ", ".join("null" if v is None else repr(v) for v in upper),
    )
    text.data = text.data[:-1] + f', "stops": {{"lower": [{limits[0]}], "upper": [{limits[1]}]}}}}'
    with pytest.raises(mjflex.ModelError, match=rf"flexure 'disc': .*{crossed}"):
        mjflex.Flexures(spec.compile())
    spec = _bodies(planar=n == 3)
    handle = mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=K)
    config = {"stop_lower": " ".join("-inf" if v is None else repr(v) for v in lower),
              "stop_upper": " ".join("inf" if v is None else repr(v) for v in upper)}  # fmt: skip
    handle.plugin.config = {**dict(handle.plugin.config), **config}
    with pytest.raises(ValueError, match=rf"flexure 'disc' .*{crossed}"):
        spec.compile()


def _two_body():
    from tests.native_cases import two_body_xml

    return mujoco.MjModel.from_xml_string(two_body_xml(2))


def test_a_freed_state_is_no_longer_live():
    """A data's state, once the data is freed, is off the registry's set of live states: a word a stale copy holds
    (a pickled copy's plugin_data, the source's address) is then never used (MuJoCo's reset passes it). Left live,
    the copy's reset read freed memory (under ASan: heap-use-after-free)."""
    native = library.lib()
    native.mjfx_states_lock_live.restype = ctypes.c_void_p
    native.mjfx_states_lock_live.argtypes = [ctypes.c_size_t]

    def live(word):
        found = native.mjfx_states_lock_live(word)
        native.mjfx_states_unlock()  # the lock is taken either way
        return found

    m = _two_body()
    d = mujoco.MjData(m)
    word = int(d.plugin_data[0])
    assert live(word) == word  # d's state: live
    import pickle

    twin = pickle.loads(pickle.dumps(d))
    assert int(twin.plugin_data[0]) == word  # the copy holds the source's word (MuJoCo restores plugin_data)
    count = native.mjfx_states_count()
    del d
    gc.collect()
    assert native.mjfx_states_count() == count - 1
    assert live(word) is None  # freed: not live, whatever address it had
    mujoco.mj_resetData(m, twin)  # the reset callback gets the freed word: it must not touch it
    mujoco.mj_step(m, twin, 3)
    assert np.isfinite(twin.qfrc_passive).all()


def test_a_state_left_by_a_data_freed_without_destroy_is_not_given_to_a_new_data_at_its_address():
    """The registry keys a state by its data's address and records the data's buffer (the generation): a data
    freed without MuJoCo calling destroy leaves its entry; a new data at the same address has another buffer and
    must not get that state (the entry is freed instead). Exercised on the registry itself, with fake addresses."""
    native = library.lib()
    for name, restype, argtypes in (
        ("mjfx_states_add", ctypes.c_int, [ctypes.c_size_t, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_void_p]),
        ("mjfx_states_find", ctypes.c_void_p, [ctypes.c_size_t, ctypes.c_size_t]),
        ("mjfx_states_remove", None, [ctypes.c_size_t]),
    ):
        function = getattr(native, name)
        function.restype, function.argtypes = restype, argtypes
    data, old_buffer, new_buffer, state = 0x7F0000001000, 0x7F0000100000, 0x7F0000200000, 0x7F0000300000
    count = native.mjfx_states_count()
    assert native.mjfx_states_add(data, old_buffer, state, None) == 0
    assert native.mjfx_states_find(data, old_buffer) == state  # the same data: its state
    assert native.mjfx_states_find(data, new_buffer) is None  # another data at that address: not its state
    assert native.mjfx_states_count() == count  # and the stale entry is gone
    assert native.mjfx_states_find(data, old_buffer) is None
    native.mjfx_states_remove(data)


def test_a_copied_data_carries_on_its_sources_divergence_tallies():
    """mj_copyData (copy.copy) continues the source's run: its divergences are the source's, counted on from there;
    a fresh data of the model has none."""
    spec = mujoco.MjSpec()
    spec.modelname = "light"
    spec.option.gravity = [0, 0, 0]
    body = spec.worldbody.add_body(name="B", pos=[0, 0, 0.5], mass=1e-6, inertia=[1e-12] * 3)
    body.explicitinertial = True
    body.add_freejoint()
    mjflex.add_flexure(spec, "spring", "world", "B", pos=[0, 0, 0.5], K=np.diag([1e-3] * 3 + [1e6] * 3))
    model = spec.compile()
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qpos[0] += 0.02
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mujoco.mj_step(model, data, 3)  # diverges (auto-reset on): the first report and its repeats are counted
    source = flex.divergences(data)["spring"]
    assert source.count >= 1
    twin = copy.copy(data)
    assert flex.divergences(twin) == {"spring": source}
    dest = mujoco.MjData(model)
    mujoco.mj_copyData(dest, model, data)
    assert flex.divergences(dest) == {"spring": source}
    assert flex.divergences(mujoco.MjData(model)) == {}


def _chain_model(n, kind):
    """``n`` hinges in one branch under the world; an element between the last two links (their dof chains hold
    n and n - 1 dofs: the chain buffer's fullest, 2 nv - 1 entries) and one grounding the last link."""
    spec = mujoco.MjSpec()
    spec.modelname = "branch"
    spec.option.gravity = [0, 0, 0]
    parent = spec.worldbody
    for i in range(n):
        parent = parent.add_body(name=f"l{i}", pos=[0, 0, -0.1] if i else [0, 0, 1], mass=0.1, inertia=[1e-4] * 3)
        parent.explicitinertial = True
        parent.add_joint(name=f"j{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[(i + 1) % 2, i % 2, 1])
    K = np.array(K_DIAG) * 0.01
    mjflex.add_flexure(spec, "last", f"l{n - 2}", f"l{n - 1}", pos=[0, 0, 1 - 0.1 * (n - 1)], K=K, kind=kind)
    mjflex.add_flexure(spec, "ground", "world", f"l{n - 1}", pos=[0.02, 0, 1 - 0.1 * n], K=K, kind=kind)
    return spec.compile()


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_the_dof_chain_buffer_at_its_fullest(kind):
    """The generalized forces of elements whose bodies' dof chains fill the buffer (2 nv - 1 dofs) are minus the
    gradient of their energy (central differences), in the plugin's table (init) and the provider's (read_table)."""
    n = 7
    model = _chain_model(n, kind)
    flex = mjflex.Flexures(model)
    rows = flex.element_table.elements[: len(flex)]
    assert [int(r["chain_a1"] - r["chain_a0"] + r["chain_b1"] - r["chain_b0"]) for r in rows] == [2 * n - 1, n]
    rng = np.random.default_rng(3)
    data = mujoco.MjData(model)
    data.qpos[:] = 0.2 * rng.normal(size=model.nq)
    with flex if kind == "record" else warnings.catch_warnings():
        mujoco.mj_forward(model, data)
    qfrc = data.qfrc_passive.copy()
    np.testing.assert_array_equal(flex.generalized_forces(data), qfrc)

    def energy(q):
        probe = mujoco.MjData(model)
        probe.qpos[:] = q
        mujoco.mj_kinematics(model, probe)
        return flex.potential_energy(probe)

    h = 1e-6
    gradient = np.array([(energy(data.qpos + h * e) - energy(data.qpos - h * e)) / (2 * h) for e in np.eye(model.nq)])
    np.testing.assert_allclose(qfrc, -gradient, rtol=0, atol=1e-6 * np.abs(qfrc).max())
    assert np.abs(qfrc).min() > 1e-4 * np.abs(qfrc).max()  # every dof feels the elements
