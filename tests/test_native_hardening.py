"""Bad input and misuse meet the native library with an error, never a crash (issue 22, items 4, 6, 7, 8, 9).

What could crash or hang runs in a child process (tests/native_cases.run_python).
"""

import itertools
import statistics
import time

import mujoco
import numpy as np
import pytest

from tests.native_cases import run_python, two_body_xml

# ------------------------------------------------------------------ item 4: NaN passes no check


@pytest.mark.parametrize(
    "edit",
    [
        ('<site name="b" pos="-0.0821053 0.0173684 0.0621053"', '<site name="b" pos="nan 0.0173684 0.0621053"'),
        ('<site name="a" pos="0.1 0.02 0" quat="0.8 0 0.6 0"', '<site name="a" pos="0.1 0.02 0" quat="nan 0 0.6 0"'),
        ('<body name="A" pos="0 0 0.5"', '<body name="A" pos="0 0 inf"'),
    ],
    ids=["site pos nan", "site quat nan", "body pos inf"],
)
def test_a_non_finite_pose_is_a_compile_error_naming_the_element(edit):
    """``dist > tol`` is false for NaN: a site at pos="nan" was accepted and every step's forces were NaN."""
    xml = two_body_xml(1).replace(*edit)
    assert xml != two_body_xml(1)
    with pytest.raises(ValueError, match=r"flexure 'e0' .*is not finite: a position, orientation or joint reference"):
        mujoco.MjModel.from_xml_string(xml)


def test_a_non_finite_pose_of_a_text_record_is_refused_too():
    import mjflex
    from tests.models import two_body_spec

    spec = two_body_spec()
    spec.site("link/b").pos = [np.nan, 0.0, 0.0]
    with pytest.raises(ValueError, match=r"flexure 'link'.*not finite"):
        mjflex.Flexures(spec.compile())


# ------------------------------------------------------------------ item 6: the duplicate-term check


def _distinct_rows(n):
    """n distinct twist exponent rows of degree 3 to 17 (no stiffness at rest), each exponent at most 16."""
    out = []
    for degree in range(3, 18):
        for combo in itertools.combinations_with_replacement(range(6), degree):
            row = [combo.count(k) for k in range(6)]
            if max(row) <= 16:
                out.append(row)
            if len(out) == n:
                return out
    raise AssertionError("not enough rows")


def _terms_xml(rows):
    exponents = " ".join(" ".join(map(str, r)) for r in rows)
    terms = (f'<config key="order" value="17"/><config key="exponents" value="{exponents}"/>'
             f'<config key="coefficients" value="{" ".join(["1e-9"] * len(rows))}"/>')  # fmt: skip
    return two_body_xml(1).replace("</instance>", terms + "</instance>")


def test_many_distinct_terms_are_checked_in_n_log_n():
    """Item 6: the repeat check compared all pairs: 100,000 distinct terms took 9 s to compile and 7.7 s per MjData.

    Complexity, measured as a same-run ratio (medians of 5; the machine is shared): making an MjData (the
    plugin's init parses and checks the terms) of 100,000 terms against one of 20,000 terms. Linear or n log n
    work gives about 5 to 6; comparing all pairs gives 25 (47 measured with the old code). The threshold, 12,
    is the geometric middle."""
    small, large = (mujoco.MjModel.from_xml_string(_terms_xml(_distinct_rows(n))) for n in (20_000, 100_000))

    def seconds(model):
        runs = []
        for _ in range(5):
            start = time.perf_counter()
            mujoco.MjData(model)
            runs.append(time.perf_counter() - start)
        return statistics.median(runs)

    t_small, t_large = seconds(small), seconds(large)
    assert t_large / t_small < 12, f"MjData of 100,000 terms {t_large:.3g} s, of 20,000 terms {t_small:.3g} s"


def test_a_repeated_term_among_many_is_named():
    rows = _distinct_rows(5000)
    rows.insert(4000, list(rows[1234]))  # row 4000 repeats row 1234
    rows.insert(4500, list(rows[4100]))  # row 4500 repeats row 4100 (not the first repeat)
    with pytest.raises(ValueError, match=r"flexure 'e0'.*exponents row 4000 repeats row 1234: list each term once"):
        mujoco.MjModel.from_xml_string(_terms_xml(rows))


# ------------------------------------------------------------------ item 8: loading before import mujoco


@pytest.mark.parametrize("call", ["library()", "register()", "library_path()"])
def test_the_library_loads_before_mujoco_is_imported(call):
    """Item 8: library() held its lock across ``import mujoco``, whose entry point calls library() again: a hang."""
    run_python(f"""
import mjflex_plugin
mjflex_plugin.{call}
import mujoco
assert mjflex_plugin.library().mjfx_status() == 1
mujoco.MjModel.from_xml_string({two_body_xml(1)!r})
""", timeout=60)  # fmt: skip


# ------------------------------------------------------------------ item 9: the ctypes helpers check their arguments


def test_every_ctypes_helper_refuses_arguments_out_of_range():
    """Item 9: mjfx_min_eigenvalue with n > 6 and mjfx_wrench_batch with top > 16 overflowed the stack; each
    helper that takes a size or an index checks it (an error code or NaN, nothing read or written outside)."""
    run_python("""
import ctypes
import numpy as np
import mujoco
from mjflex.native import library as _native
from tests.native_cases import two_body_xml
lib = _native.lib()
big = np.zeros(10**6)
assert np.isnan(lib.mjfx_min_eigenvalue(big.ctypes.data, 7))
assert np.isnan(lib.mjfx_min_eigenvalue(big.ctypes.data, 100000))
assert np.isnan(lib.mjfx_min_eigenvalue(big.ctypes.data, -1))
assert lib.mjfx_min_eigenvalue(np.diag([3.0, 1.0, 2.0]).ctypes.data, 3) == 1.0
err = ctypes.create_string_buffer(200)
lib.mjfx_check_matrix.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                                  ctypes.c_int]
assert lib.mjfx_check_matrix(big.ctypes.data, 7, b"K", 1, err, 200) == -1 and b"3x3 or a 6x6" in err.value

n = 3
R = np.tile(np.eye(3), (n, 1, 1)); p = np.zeros((n, 3)); K = np.tile(np.eye(6), (n, 1, 1))
out, power = np.zeros((n, 6)), np.zeros(n)
exps, coefs = np.zeros((1, 8), np.int32), np.ones(1)
exps[0, 0] = 3
args = [R.ctypes.data, p.ctypes.data, R.ctypes.data, p.ctypes.data, K.ctypes.data]
for top, nterms, method in ((17, 1, 0), (10**6, 1, 0), (-1, 0, 0), (2, 1, 0), (3, 1, 7), (3, -5, 0)):
    rc = lib.mjfx_wrench_batch(n, method, *args, None, 0, None, None, None, None, exps.ctypes.data,
                               coefs.ctypes.data, nterms, top, out.ctypes.data, power.ctypes.data)
    assert rc == -1 and np.isnan(out).all(), (top, nterms, method)
    energy = np.zeros(n)
    assert lib.mjfx_potential_batch(n, method, *args, exps.ctypes.data, coefs.ctypes.data, nterms, top,
                                    energy.ctypes.data) == -1 and np.isnan(energy).all()
assert lib.mjfx_wrench_batch(n, 0, *args, None, 1, None, None, None, None, exps.ctypes.data, coefs.ctypes.data,
                             1, 3, out.ctypes.data, power.ctypes.data) == -1  # viscous without B or velocities
assert lib.mjfx_wrench_batch(n, 0, *args, None, 0, None, None, None, None, exps.ctypes.data, coefs.ctypes.data,
                             1, 3, out.ctypes.data, power.ctypes.data) == 0 and np.isfinite(out).all()
assert lib.mjfx_twist_batch(-1, None, None, None, None, None) == -1

m = mujoco.MjModel.from_xml_string(two_body_xml(1))
d = mujoco.MjData(m)
names, values = (ctypes.c_char_p * 1)(b"e"), (ctypes.c_char_p * 17)(*[b""] * 17)
for n, nm, vs in ((-1, names, values), (1, None, values), (1, names, None), (1, names, (ctypes.c_char_p * 17)())):
    assert not lib.mjfx_read_table(m._address, d._address, n, nm, vs, err, 200)
    assert b"invalid arguments" in err.value
assert not lib.mjfx_read_table(None, d._address, 0, None, None, err, 200)
assert lib.mjfx_check_config(b"e", None, err, 200) == -1
assert lib.mjfx_check_config(b"e", (ctypes.c_char_p * 17)(), err, 200) == -1
lib.mjfx_table_copy(None, None, None, None, None, None)  # no table: nothing written
sizes = (ctypes.c_int * 3)(7, 7, 7)
lib.mjfx_table_sizes(None, sizes)
assert list(sizes) == [0, 0, 0]

import mjflex
flex = mjflex.Flexures(m)
tables = flex._tables
good = tables.elements.copy()
for field, value in (("site_a", m.nsite), ("body_b", -2), ("chain_b1", 10**6), ("free_a", m.nv - 3),
                     ("terms_hi", 5), ("terms_top", 17), ("method", 2), ("kstruct", 3)):
    tables.elements[:] = good
    tables.elements[field][0] = value
    try:
        flex.wrenches(d)
    except RuntimeError as exc:
        assert "does not fit its model" in str(exc)
    else:
        raise AssertionError(f"{field} = {value} was evaluated")
tables.elements[:] = good
check = (m._address, good.ctypes.data, 1, tables.chain.ctypes.data, len(tables.chain), tables.exps.ctypes.data,
         tables.coefs.ctypes.data, len(tables.coefs))
assert lib.mjfx_check_rows(*check) == -1
bad_chain = np.full(len(tables.chain), m.nv, np.int32)
assert lib.mjfx_check_rows(*check[:3], bad_chain.ctypes.data, *check[4:]) == 0
mujoco.mj_forward(m, d)
assert np.isfinite(flex.wrenches(d)).all()
""")


# ------------------------------------------------------------------ item 7: the dispatcher's records in threads


def test_more_datas_than_watch_records_in_threads():
    """Item 7: with all 64 watch entries of a text-record model taken, threads reclaim entries; each entry is used
    by one thread at a time (tests/test_native_sanitizers.py runs this under ThreadSanitizer). Here: the forces are
    exact, whatever the contention."""
    run_python(
        """
import threading
import mujoco, numpy as np, mjflex
from tests.models import two_body_spec, B_DEMO
m = two_body_spec(B=B_DEMO).compile()
flex = mjflex.Flexures(m)
datas = [mujoco.MjData(m) for _ in range(160)]
for k, d in enumerate(datas):
    d.qvel[:] = 0.01 * k
expected = []
with flex:
    for d in datas:
        twin = mujoco.MjData(m); twin.qvel[:] = d.qvel
        mujoco.mj_step(m, twin, 20)
        expected.append(twin.qpos.copy())

    def run(k):
        mine = datas[k::4]
        for _ in range(20):
            for d in mine:
                mujoco.mj_step(m, d)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    assert all(np.array_equal(d.qpos, e) for d, e in zip(datas, expected))
""",
        timeout=300,
    )
