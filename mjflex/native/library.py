"""ctypes bindings of mjflex's native library (``mjflex/native``): the one implementation of the per-step math.

The library is found and loaded once per process by :mod:`mjflex_plugin` (the same copy that
``import mujoco`` registered as the engine plugin ``mjflex.flexure``). Its C functions read
``mjModel`` / ``mjData`` through the MuJoCo headers they were compiled against (the version is
checked before loading), so Python passes ``model._address`` and ``data._address``.

Every force, of both element forms, comes from this library; there is no other implementation
(``mjflex.core`` is the independent reference the tests hold it to). ``import mjflex`` does not
need it: the core, the stiffness from geometry and reading or writing records in a spec work
without it. The first call that does (building a :class:`mjflex.Flexures`, adding a plugin
element, ...) gets :func:`lib`, which raises :class:`NativeLibraryError` saying how to install it
(mjflex's binary wheel, or a C compiler for a source build) when it is missing or was built for
another MuJoCo.

The element table
-----------------
``ELEMENT_DTYPE`` mirrors the C struct ``mjfxElement`` (``mjflex/native/elements.h``): one row
per element, laid out once by the C library for both forms (:func:`read_table`). Its offsets are
checked against the library's (``mjfx_element_field``) when the library loads, so Python and C
cannot drift apart.
"""

import ctypes
import threading

import numpy as np

from mjflex_plugin import NativeLibraryError

#: Modes of :func:`evaluate` (bits, as ``MJFX_*`` in elements.h).
APPLY, WRENCH, ENERGY, POWER, COORDS = 1, 2, 4, 8, 16
#: Structure codes of K and B (``MJFX_FULL``, ``MJFX_DIAGONAL``, ``MJFX_ZERO``).
FULL, DIAGONAL, ZERO = 0, 1, 2
#: Columns of a term's exponent row in the tables (twist uses the first 6).
TERM_COLUMNS = 8

_INT_FIELDS = (
    "site_a", "site_b", "body_a", "body_b", "method", "enabled", "viscous", "offset", "free_a", "free_b",
    "chain_a0", "chain_a1", "chain_b0", "chain_b1", "terms_lo", "terms_hi", "terms_top", "kstruct", "bstruct",
    "stops", "stop_damped", "rest",
)  # fmt: skip
#: One element of a model, as the C loop reads it (``mjfxElement``; the fields the per-step loop reads first).
ELEMENT_DTYPE = np.dtype(
    [*((f, np.int32) for f in _INT_FIELDS), ("qa", np.float64, (4,)), ("qb", np.float64, (4,)),
     ("p0", np.float64, (3,)), ("lever_a", np.float64, (3,)), ("lever_b", np.float64, (3,)),
     ("inv_mass", np.float64), ("inv_inertia", np.float64), ("kdiag", np.float64, (6,)),
     ("bdiag", np.float64, (6,)), ("K", np.float64, (36,)), ("B", np.float64, (36,)), ("R0", np.float64, (9,)),
     ("stop_lo", np.float64, (6,)), ("stop_hi", np.float64, (6,)), ("stop_k", np.float64, (6,)),
     ("stop_b", np.float64, (6,))],
    align=True,
)  # fmt: skip

_LOCK = threading.Lock()
_STATE = {}
_P = ctypes.c_void_p
_I = ctypes.c_int
_D = ctypes.c_double
_DP = ctypes.POINTER(ctypes.c_double)
_IP = ctypes.POINTER(ctypes.c_int)


class Verdict(ctypes.Structure):
    """``mjfxVerdict``: what a look at an mjData's divergence watch asks to report."""

    _fields_ = (("element", _I), ("first", _I), ("nonfinite", _I), ("accel", _D), ("step", _D), ("bad", _I))


class Scan(ctypes.Structure):
    """``mjfxScan``."""

    _fields_ = (("nonfinite", _I), ("largest", _I), ("accel", _D))


_SIGNATURES = {
    "mjfx_element_field": (ctypes.c_long, [ctypes.c_char_p]),
    "mjfx_attribute": (ctypes.c_char_p, [_I]),
    "mjfx_evaluate": (_I, [_P, _P, _P, _I, _P, _P, _P, _I, _P, _P, _P, _P]),
    "mjfx_evaluate_checked": (_I, [_P, _P, _P, _I, _P, _I, _P, _P, _I, _I, _P, _P, _P, _P]),
    "mjfx_check_rows": (_I, [_P, _P, _I, _P, _I, _P, _P, _I]),
    "mjfx_read_table": (_P, [_P, _P, _I, _P, _P, ctypes.c_char_p, _I]),
    "mjfx_table_sizes": (None, [_P, _P]),
    "mjfx_table_copy": (None, [_P, _P, _P, _P, _P, _P]),
    "mjfx_table_values": (None, [_P, _P, _P, _P, _P]),
    "mjfx_free_table": (None, [_P]),
    "mjfx_check_config": (_I, [ctypes.c_char_p, _P, ctypes.c_char_p, _I]),
    "mjfx_parse_values": (_I, [ctypes.c_char_p, _I, _P, _P, _P, _P, _P, _I, ctypes.c_char_p, _I]),
    "mjfx_schema_text": (ctypes.c_char_p, [_I, ctypes.c_char_p]),
    "mjfx_schema_number": (_D, [_I, ctypes.c_char_p]),
    "mjfx_constant": (_D, [ctypes.c_char_p]),
    "mjfx_offsets_coincide": (_I, [_P, _P, _P, _P]),
    "mjfx_registry_capacity": (_I, []),
    "mjfx_registry_watches_size": (ctypes.c_size_t, [_I]),
    "mjfx_registry_publish": (_I, [_I, _P, _I, _P, _P, _I, _P, _P, _I, _P, _P, _P]),
    "mjfx_snapshot_size": (ctypes.c_size_t, [_P]),
    "mjfx_snapshot_take": (None, [_P, _P]),
    "mjfx_snapshot_same": (_I, [_P, _P, _I]),
    "mjfx_registry_clear": (None, [_I]),
    "mjfx_registry_used": (_I, []),
    "mjfx_registry_watch": (_P, [_P, _I, _P]),
    "mjfx_registry_watches_init": (None, [_P, _I]),
    "mjfx_set_previous": (None, [_P]),
    "mjfx_dispatch": (_I, [_P, _P, _I, _P]),
    "mjfx_report_text": (_I, [_P, _P, ctypes.c_char_p, ctypes.c_char_p, _I]),
    "mjfx_errors_caught_here": (_I, []),
    "mjfx_report_raises": (_I, [_P]),
    "mjfx_plugin_watch": (_P, [_P, _P]),
    "mjfx_watch_size_of": (_I, [_P]),
    "mjfx_watch_first": (_I, [_P, _I, _P]),
    "mjfx_watch_peek": (None, [_P, _P, _P, _P]),
    "mjfx_wrench_batch": (_I, [_I, _I, *[_P] * 6, _I, *[_P] * 6, _I, _I, _P, _P]),
    "mjfx_potential_batch": (_I, [_I, _I, *[_P] * 7, _I, _I, _P]),
    "mjfx_twist_batch": (_I, [_I, _P, _P, _P, _P, _P]),
    "mjfx_min_eigenvalue": (_D, [_P, _I]),
    "mjfx_series_coefficients": (_I, [_P, _P, _I]),
    "mjfx_header_version": (_I, []),
    "mjfx_is_instance": (_I, [_P, _I]),
    "mjfx_live_instances": (ctypes.c_long, []),
    "mjfx_states_count": (ctypes.c_long, []),
    "mjfx_stateless_reads": (ctypes.c_long, []),
    "mjfx_set_lanes": (_I, [_I]),
    "mjfx_lanes_available": (_I, [_I]),
    "mjfx_lanes": (_I, []),
    "mjfx_angle_coefs": (None, [_D, _D, _DP, _DP, _DP]),
}


def _bind(lib):
    for name, (restype, argtypes) in _SIGNATURES.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, argtypes
    size = lib.mjfx_element_field(None)
    for name in ELEMENT_DTYPE.names:
        if lib.mjfx_element_field(name.encode()) != ELEMENT_DTYPE.fields[name][1]:
            raise NativeLibraryError(
                f"mjflex: the native mjfxElement.{name} is not where ELEMENT_DTYPE has it; rebuild mjflex"
            )
    if size != ELEMENT_DTYPE.itemsize:
        raise NativeLibraryError(
            f"mjflex: the native mjfxElement has {size} bytes, ELEMENT_DTYPE {ELEMENT_DTYPE.itemsize}; rebuild mjflex"
        )
    return lib


def lib():
    """The native library (ctypes), loaded and bound once per process; raises :class:`NativeLibraryError`.

    The error names the cause (not built, built for another MuJoCo, another copy registered
    first) and the fix: install mjflex's binary wheel, or a C compiler and install from source.
    """
    with _LOCK:
        if "lib" not in _STATE:
            import mjflex_plugin  # late: finds and loads the library on first use (import mjflex works without it)

            _STATE["lib"] = _bind(mjflex_plugin.library())  # raises NativeLibraryError (not kept: may be fixed)
        return _STATE["lib"]


def lanes() -> int:
    """Elements the native loop evaluates at once (vector lanes: 4 where the CPU has AVX, else 2)."""
    return int(lib().mjfx_lanes())


def plugin_instances(model) -> list[int]:
    """Ids of the model's mjflex.flexure plugin instances."""
    if not model.nplugin:
        return []
    native = lib()
    return [i for i in range(model.nplugin) if native.mjfx_is_instance(model._address, i)]


def plugin_attributes() -> tuple[str, ...]:
    """The configuration attributes of the plugin, in the order MuJoCo stores their values."""
    native = lib()
    out, i = [], 0
    while (name := native.mjfx_attribute(i)) is not None:
        out.append(name.decode())
        i += 1
    return tuple(out)


def _ptr(a):
    return None if a is None else a.ctypes.data


def evaluate(model, data, elements, chain, exps, coefs, mode, *, qfrc=None, out6=None, out1=None, n=None):
    """Run the C loop on ``data``; returns -1 or the index of the first element with a non-finite wrench.

    The C side checks the tables against the model first (``mjfx_evaluate_checked``): a table that would
    index past the model's arrays raises RuntimeError instead of reading memory it does not own.
    """
    native = lib()
    count = len(elements) if n is None else n
    if count > len(elements):
        raise ValueError(f"mjflex: {count} elements asked of a table of {len(elements)}")
    status = native.mjfx_evaluate_checked(
        model._address, data._address, _ptr(elements), count, _ptr(chain), len(chain), _ptr(exps), _ptr(coefs),
        len(coefs), mode, _ptr(qfrc), _ptr(out6), _ptr(out1), None,
    )  # fmt: skip
    if status == -2:
        raise RuntimeError("mjflex: an element table does not fit its model (an index out of range); rebuild it")
    return status


def _strings(texts):
    return (ctypes.c_char_p * max(len(texts), 1))(*(t.encode() for t in texts))


def read_table(model, data, records):
    """The element table of ``model``, read by the C library (``mjfx_read_table``): its text records, then its plugin
    instances in order. ``records``: ``[(element, values)]`` of the text records, each with the values of the plugin
    configuration it is equal to (one string per attribute, in :func:`plugin_attributes` order). ``data`` (of
    ``model``) gives the reference configuration's kinematics (put back after). Returns ``(elements, chain, exps,
    coefs, instances, values)``: ``instances[e]`` the plugin instance of row ``e`` (-1 for a record); the arrays are
    never empty (one zero row or a trailing 0: valid addresses for the C loop); ``values[e]`` what C read of row
    ``e``'s configuration, ``(count, first, num)`` (:func:`parse_values`). Raises ValueError with the message of the
    first element that C refuses.
    """
    native = lib()
    names = _strings([name for name, _ in records])
    values = _strings([v for _, strings in records for v in strings])
    err = ctypes.create_string_buffer(4096)
    table = native.mjfx_read_table(model._address, data._address, len(records), ctypes.cast(names, _P),
                                   ctypes.cast(values, _P), err, len(err))  # fmt: skip
    if not table:
        raise ValueError(err.value.decode(errors="replace"))
    try:
        sizes = (ctypes.c_int * 4)()
        native.mjfx_table_sizes(table, sizes)
        n, nchain, nterms, nnum = sizes
        elements = np.zeros(max(n, 1), dtype=ELEMENT_DTYPE)
        chain = np.zeros(nchain + 1, dtype=np.int32)
        exps = np.zeros((max(nterms, 1), TERM_COLUMNS), dtype=np.int32)
        coefs, instances = np.zeros(max(nterms, 1)), np.zeros(max(n, 1), dtype=np.int32)
        native.mjfx_table_copy(table, *(_ptr(a) for a in (elements, chain, exps, coefs, instances)))
        count, first = (np.zeros((max(n, 1), len(plugin_attributes())), np.int32) for _ in range(2))
        base, num = np.zeros(max(n, 1), np.int32), np.zeros(max(nnum, 1))
        native.mjfx_table_values(table, *(_ptr(a) for a in (count, first, base, num)))
    finally:
        native.mjfx_free_table(table)
    values = [(count[e], first[e], num[base[e] :]) for e in range(n)]
    return elements, chain, exps, coefs, tuple(int(i) for i in instances[:n]), values


def parse_values(element: str, form: str, strings):
    """What the C library reads of element ``element``'s configuration, ``strings`` (one per attribute, in
    :func:`plugin_attributes` order), written in ``form`` (``"plugin"``, ``"record"`` or ``"arguments"``:
    ``mjfx_parse_values``, the rules of the plugin's compile errors, without a model): ``(count, first, num,
    element)``, per attribute how many numbers it has and where they start in ``num`` (for a name or a JSON object,
    the length and byte offset of its value in its string; -1: not given), and its ``ELEMENT_DTYPE`` row. Raises
    ValueError with the C library's message.
    """
    native, values, err = lib(), _strings(strings), ctypes.create_string_buffer(4096)
    count, first, row = np.zeros(len(strings), np.int32), np.zeros(len(strings), np.int32), np.zeros(1, ELEMENT_DTYPE)
    code = int(constant("FORM_" + form.upper()))
    cap = 64 + sum(len(s) for s in strings)  # numbers are at least a character each, and K or B at most 36
    for _ in range(2):
        num = np.zeros(cap)
        n = native.mjfx_parse_values(element.encode(), code, ctypes.cast(values, _P), _ptr(row), _ptr(count),
                                     _ptr(first), _ptr(num), cap, err, len(err))  # fmt: skip
        if n < 0:
            raise ValueError(err.value.decode(errors="replace"))
        if n <= cap:
            return count, first, num[:n], row[0]
        cap = n
    raise RuntimeError("mjflex: mjfx_parse_values read another size twice")


def constant(name: str) -> float:
    """A constant of the C library (``mjfx_constant``: tolerances, limits, codes), NaN for an unknown name."""
    return float(lib().mjfx_constant(name.encode()))


def offsets_coincide(model, mine, other) -> tuple[bool, float, float]:
    """Whether the rest offsets of one element in two tables (rows ``mine``, ``other``) coincide within the
    element's tolerances in ``model``, and their distance [m] and angle [rad]."""
    a, b, gap = np.ascontiguousarray(mine), np.ascontiguousarray(other), np.zeros(2)
    same = lib().mjfx_offsets_coincide(model._address, a.ctypes.data, b.ctypes.data, gap.ctypes.data)
    return bool(same), float(gap[0]), float(gap[1])


def report_text(model, verdict, element: str) -> str:
    buf = ctypes.create_string_buffer(1024)
    lib().mjfx_report_text(model._address, ctypes.byref(verdict), element.encode(), buf, len(buf))
    return buf.value.decode(errors="replace")
