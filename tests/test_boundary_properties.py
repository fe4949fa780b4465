"""Property-based checks of the boundary (hypothesis, derandomized: the same examples on every run).

Records: valid element records, then with one key's value replaced by a random JSON value (or
keys repeated, NaN/Infinity written, a huge integer), parsed as a model file's record is. Core
calls: valid poses and stiffness, then one argument replaced by None, a complex, boolean or text
array, a huge integer, a non-finite entry, a wrong or ragged shape. Whatever comes in: the only
errors are the documented ones (ValueError, TypeError; ModelError for a model) with a message
that names the key or argument, no call takes long, what is accepted means what it says (the
record's values are the JSON values, untouched), and valid calls agree with the element written
from the definitions (``tests/reference_element.py``).
"""

import json
import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mjflex
from mjflex.mjcf import schema

from .reference_element import reference_wrench, rotation_matrix

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])  # fmt: skip
SLOW_CALL = 2.0  # [s]: far beyond any call here (each takes well under 10 ms once compiled)
BIG = 10**400

# ------------------------------------------------------------------------------------------ records

json_scalars = (st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.just(BIG) | st.just(-BIG)
                | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8))  # fmt: skip
json_values = st.recursive(
    json_scalars,
    lambda inner: st.lists(inner, max_size=7) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=40,
)


@st.composite
def valid_records(draw):
    n = draw(st.sampled_from([6, 3]))
    L = np.reshape(draw(st.lists(st.floats(-0.5, 0.5), min_size=n * n, max_size=n * n)), (n, n))
    L = np.tril(L, -1) + np.diag(draw(st.lists(st.floats(0.2, 2.0), min_size=n, max_size=n)))
    K = L @ L.T * 10.0 ** draw(st.integers(-3, 6))
    payload = {"mjflex": 1, "method": draw(st.sampled_from(["twist", "dualquat"]))}
    payload["K"] = K.tolist() if draw(st.booleans()) else np.diag(K).tolist()
    if draw(st.booleans()):
        payload["B"] = (0.01 * K).tolist()
    for key in ("enabled", "viscous"):
        if draw(st.booleans()):
            payload[key] = draw(st.booleans())
    if draw(st.booleans()):
        payload["strain_per_radian"] = draw(st.floats(0.0, 10.0) | st.integers(0, 10))
    if draw(st.booleans()):
        payload["source"] = draw(st.dictionaries(st.text(max_size=4), st.integers() | st.text(max_size=4), max_size=3))
    return payload


def _is_number(v):
    return type(v) in (int, float) and abs(v) <= 1e308 and math.isfinite(v)


def _leaves(v):
    return [x for item in v for x in _leaves(item)] if isinstance(v, list) else [v]


def _check_accepted(rec, payload):
    """What a record was accepted as is what its JSON says (an independent statement of the rules)."""
    assert payload["mjflex"] == 1 and type(payload["mjflex"]) is int
    assert all(_is_number(x) for x in _leaves(payload["K"]))
    K = np.array(payload["K"], dtype=float)
    np.testing.assert_array_equal(rec.K, np.diag(K) if K.ndim == 1 else K)
    if payload.get("B") is not None:
        assert all(_is_number(x) for x in _leaves(payload["B"]))
    given = {k: v for k, v in payload.items() if v is not None}  # null is "not given", for every key
    assert rec.enabled is given.get("enabled", True) and rec.viscous is given.get("viscous", True)
    strain = given.get("strain_per_radian")
    assert (rec.strain_per_radian is None) if strain is None else (_is_number(strain) and rec.strain_per_radian >= 0)
    assert rec.method == given.get("method", "twist")


@SETTINGS
@given(valid_records(), st.sampled_from([None, *schema.keys(), "unknown"]), json_values, st.integers(0, 3))
def test_records_are_accepted_as_written_or_refused_naming_the_key(payload, key, value, mangle):
    text = json.dumps(payload)
    if key is not None:
        payload = {**payload, key: value}
        text = json.dumps(payload)  # NaN / Infinity are written as such: strict JSON must refuse them
        if mangle == 1:  # the key written twice: first the valid value, then the random one
            text = text[:-1] + f", {json.dumps(key)}: {json.dumps(value)}" + "}"
    started = time.perf_counter()
    try:
        rec = schema.parse_text("e", text)
    except ValueError as exc:
        message = str(exc)
        assert key is not None, f"a valid record was refused: {message}"
        assert len(message) < 1200, "a bad value must be quoted shortened"
        assert key in message, message  # the key at fault is named (JSON errors name it too)
    else:
        assert mangle != 1 or key is None, "a key given twice was accepted"
        _check_accepted(rec, json.loads(text, parse_constant=lambda c: float(c)))
    assert time.perf_counter() - started < SLOW_CALL


# ------------------------------------------------------------------------------------------ core calls

unit = st.floats(-1.0, 1.0)
rotvecs = st.tuples(unit, unit, unit).map(lambda v: 1.4 * np.array(v))  # angles below 2.5 rad: one log branch


def _quat(rotvec):
    angle = np.linalg.norm(rotvec)
    axis = rotvec / angle if angle > 0 else np.array([1.0, 0.0, 0.0])
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis]


@st.composite
def stiffness(draw):
    L = np.reshape(draw(st.lists(st.floats(-0.5, 0.5), min_size=36, max_size=36)), (6, 6))
    L = np.tril(L, -1) + np.diag(draw(st.lists(st.floats(0.3, 2.0), min_size=6, max_size=6)))
    return L @ L.T * np.outer(*[np.array([1, 1, 1, 100, 100, 100.0])] * 2)


def _corruptions(value):
    a = np.asarray(value, dtype=float)
    first = (0,) * a.ndim
    nan = a.copy()
    nan[first] = np.nan
    ragged = [list(a.ravel()), [1.0]]
    huge = a.ravel().tolist()
    huge[0] = BIG
    return {
        "None": None, "complex": a + 1e-3j, "bool": a > 0, "text": a.astype(str), "text list": a.astype(str).tolist(),
        "nan": nan, "inf": np.where(a == a[first], np.inf, a), "huge int": huge,
        "wrong shape": np.zeros(a.shape[:-1] + (4,)),
        "ragged": ragged, "scalar text": "1.0", "dict": {"a": 1}, "bool list": [True] * a.size,
    }  # fmt: skip


CORRUPTIONS = list(_corruptions(np.eye(3)))


@pytest.fixture(scope="module", autouse=True)
def compiled_core():
    """The core's numba kernels compiled before any call is timed: SLOW_CALL guards against hangs in a call, not
    against numba's one-off compilation (seconds in a fresh clone, whose kernel cache is empty)."""
    for method in ("twist", "dualquat"):
        for function in (mjflex.potential, mjflex.wrench_on_b):
            function(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), np.eye(6), method=method)


@SETTINGS
@given(rotvecs, rotvecs, st.tuples(unit, unit, unit), st.tuples(unit, unit, unit), stiffness(),
       st.sampled_from(["twist", "dualquat"]),
       st.sampled_from([None, "R_WA", "p_WA", "R_WB", "p_WB", "K"]), st.sampled_from(CORRUPTIONS))  # fmt: skip
def test_core_calls_refuse_bad_arguments_by_name_and_agree_with_the_definitions(a, b, pa, pb, K, method, bad, how):
    q_a, q_b = _quat(a), _quat(b)
    args = {"R_WA": rotation_matrix(q_a), "p_WA": 0.1 * np.array(pa), "R_WB": rotation_matrix(q_b),
            "p_WB": 0.1 * np.array(pb), "K": K}  # fmt: skip
    if bad is not None:
        args[bad] = _corruptions(args[bad])[how]
    for function in (mjflex.potential, mjflex.wrench_on_b):
        started = time.perf_counter()
        try:
            out = function(**args, method=method)
        except (ValueError, TypeError) as exc:
            assert bad is not None, f"valid arguments refused: {exc}"
            assert bad in str(exc) and len(str(exc)) < 1200, str(exc)
            continue
        finally:
            assert time.perf_counter() - started < SLOW_CALL
        assert bad is None, f"{function.__name__} accepted {bad} = {how}"
        assert np.all(np.isfinite(out))
        if function is mjflex.wrench_on_b:
            ref = reference_wrench(method, q_a, args["p_WA"], q_b, args["p_WB"], np.zeros(6), np.zeros(6), K,
                                   np.zeros((6, 6)))  # fmt: skip
            # relative poses come from differences of O(1) rotations and positions: absolute round-off ~1e-16 x K
            np.testing.assert_allclose(out, ref, rtol=1e-8, atol=1e-13 * np.abs(K).max())
        else:
            assert out >= 0.0


@SETTINGS
@given(rotvecs, st.tuples(unit, unit, unit), st.sampled_from([None, "R", "p"]), st.sampled_from(CORRUPTIONS))
def test_transforms_refuse_bad_arguments_by_name(rotvec, p, bad, how):
    """twist_from_transform, dual_quaternion_from_transform, stiffness_in_frame: the same rules; valid calls
    round-trip (transform_from_twist / transform_from_dual_quaternion give the pose back)."""
    args = {"R": rotation_matrix(_quat(rotvec)), "p": np.array(p)}
    if bad is not None:
        args[bad] = _corruptions(args[bad])[how]
    calls = [
        (mjflex.twist_from_transform, lambda: mjflex.twist_from_transform(args["R"], args["p"]),
         lambda xi: mjflex.transform_from_twist(xi)),
        (mjflex.dual_quaternion_from_transform, lambda: mjflex.dual_quaternion_from_transform(args["R"], args["p"]),
         lambda q: mjflex.transform_from_dual_quaternion(q)),
        (mjflex.stiffness_in_frame, lambda: mjflex.stiffness_in_frame(np.eye(6), args["R"], args["p"]), None),
    ]  # fmt: skip
    for function, call, inverse in calls:
        try:
            out = call()
        except (ValueError, TypeError) as exc:
            assert bad is not None, f"{function.__name__}: valid arguments refused: {exc}"
            assert len(str(exc)) < 1200
            continue
        assert bad is None, f"{function.__name__} accepted {bad} = {how}"
        assert np.all(np.isfinite(out))
        if inverse is not None:
            R, p = inverse(out)
            np.testing.assert_allclose(R, args["R"], atol=1e-12)
            np.testing.assert_allclose(p, args["p"], atol=1e-12)


@pytest.mark.parametrize("how", CORRUPTIONS)
def test_every_corruption_is_refused_for_every_argument(how):
    """The deterministic core of the property: each corruption of each argument, once (fast)."""
    args = {"R_WA": np.eye(3), "p_WA": np.zeros(3), "R_WB": np.eye(3), "p_WB": np.array([0.01, 0, 0]),
            "K": np.eye(6)}  # fmt: skip
    for name in args:
        bad = {**args, name: _corruptions(args[name])[how]}
        for function in (mjflex.potential, mjflex.wrench_on_b):
            with pytest.raises((ValueError, TypeError), match=name):
                function(**bad)
