"""Damped end stops and rest poses on MuJoCo Warp (``mjflex.warp``), Warp's CPU device, against the C engine.

The bounds are tests/warp_bounds.py's (derived from float32 rounding; nothing tuned), with the stops' damping added
to the magnitudes the arithmetic combines: ``b_i |zdot_i|`` in the wrench and ``b_i zdot_i^2 + k_i over_i |zdot_i|``
in the power, ``zdot`` the rates of the stop coordinates (central differences along the state's velocity).
"""

import mujoco
import numpy as np
import pytest
import warp as wp

import mjflex
import mjflex.warp as mw
from tests import warp_bounds as wb
from tests.test_stop_damping import K_BUSH, _random_state, damped_spec
from tests.test_warp import _state_data, _warp_queries, _worlds


@pytest.fixture(scope="module", autouse=True)
def cpu():
    with wp.ScopedDevice("cpu"):
        yield


def _rates(model, flex, data, h=1e-6):
    """The stop coordinates' rates along the state's velocity (central differences)."""
    out = []
    for sign in (1.0, -1.0):
        d = mujoco.MjData(model)
        d.qpos[:] = data.qpos
        mujoco.mj_integratePos(model, d.qpos, data.qvel, sign * h)
        mujoco.mj_kinematics(model, d)
        out.append(flex.stop_coordinates(d))
    return (out[0] - out[1]) / (2 * h)


def _bounds(model, data, flex, arith):
    bound = wb.bounds(model, data, flex, arith)
    n = len(flex)
    el = flex.element_table.elements[:n]
    stops = wb.stop_terms(flex, data)
    zdot = np.abs(_rates(model, flex, data))
    b = el["stop_b"]
    grow = (1.0 + np.linalg.norm(np.abs(flex.displacements(data)), axis=1)) ** 2
    gamma = wb.N_ARITH * arith
    damp = b * zdot
    wrench = np.zeros((n, 6))
    for part in (slice(0, 3), slice(3, 6)):
        wrench[:, part] = (grow * np.linalg.norm(damp[:, part], axis=1))[:, None]
    bound["wrench"] += gamma * wrench
    bound["power"] += gamma * grow * np.sum(damp * zdot + stops["k"] * stops["overshoot"] * zdot, axis=1)
    bound["qfrc"] += gamma * wb._through_jacobians(model, data, flex, wrench)
    return bound


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_damped_stops_and_rest_poses_match_the_c_engine(precision):
    """Damped stops (engaged, bodies moving) and rest poses, both methods, beside undamped stops: wrenches (about
    site b for elements with a rest pose), generalized forces, energies, dissipated powers and stop coordinates within
    the derived bounds; and the damping matters: the same elements without it are outside the power's bound."""
    rng = np.random.default_rng(12)
    qpos0 = _random_state(damped_spec().compile(), rng)
    model = damped_spec(qpos0, seed=3, B=1e-3 * K_BUSH).compile()
    undamped = mjflex.Flexures(damped_spec(qpos0, seed=3, B=1e-3 * K_BUSH, damping=False).compile())
    flex = mjflex.Flexures(model)
    states = []
    for _ in range(3):
        qpos = qpos0.copy()
        for j in range(model.njnt):
            qpos[7 * j : 7 * j + 3] += 1e-5 * rng.normal(size=3)  # near the placed stops: most stay engaged
        states.append((qpos, rng.normal(size=model.nv)))
    m = mw.put_model(model, precision=precision)
    got = _warp_queries(m, _worlds(model, m, states))
    arith = wb.U64 if precision == "float64" else wb.U32
    mattered = False
    for i, (qpos, qvel) in enumerate(states):
        data = _state_data(model, qpos, qvel)
        ref, bound = wb.c_queries(flex, data), _bounds(model, data, flex, arith)
        for key in ("wrench", "qfrc", "energy", "power", "stops"):
            err = np.abs(got[key][i] - ref[key])
            assert (err <= bound[key]).all(), (key, i, float(np.max(err / np.maximum(bound[key], 1e-300))))
        mattered |= (np.abs(undamped.dissipation_powers(data) - got["power"][i]) > bound["power"]).any()
    assert mattered
    assert flex.element_table.elements["stop_damped"][:3].all() and flex.element_table.elements["rest"][:2].all()
