"""The process-global ``mjcb_passive`` callback, shared by every :class:`mjflex.Flexures`.

MuJoCo has one passive callback per process, called for every model. mjflex installs one
dispatcher and keeps a registry of the models that have elements; every other model
(including the temporary ones MuJoCo builds while compiling) is left untouched.

Install and uninstall between steps, not while another thread is stepping a registered
model. The dispatcher is native code (a numba ``cfunc`` given to MuJoCo as a C function pointer):
it needs neither the GIL nor the Python bindings' wrapper lookup, so compiling models while
it is installed works (a Python callback makes ``mj_compile`` fail with "Python exception
raised"), ``mujoco.rollout`` threads can run it, and it costs no Python call per step. It finds
the arrays of ``mjData`` through offsets verified at start-up (:mod:`._layout`). A non-finite
wrench makes it call ``mju_error`` with the element's name, which the bindings raise as
``mujoco.FatalError`` from ``mj_step``.

A Python dispatcher is used instead when a Python callback was already installed (it is
chained, and with it the compile limitation is already there) or when the struct layout of
the installed MuJoCo cannot be verified.
"""

import ctypes
import os
import warnings

import mujoco
import numpy as np
from numba import cfunc, njit, types

from . import _kernels as k
from ._layout import LayoutError, verified_offsets

CAPACITY = 256
_REGISTRY = np.zeros(k.HEADER + k.SLOT * CAPACITY, dtype=np.int64)
_PROVIDERS = {}  # model address -> provider (keeps the provider, its model and its arrays alive)
_STATE = {"callback": None, "previous": None, "native": {}}
_PROTO = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)


def _libmujoco():
    folder = os.path.dirname(mujoco.__file__)
    names = sorted(f for f in os.listdir(folder) if f.startswith(("libmujoco.so", "libmujoco.", "mujoco.dll")))
    if not names:
        raise LayoutError("libmujoco not found next to the mujoco package")
    return ctypes.CDLL(os.path.join(folder, names[0]))


def _native_header():
    """Fill the registry header; raises LayoutError when the layout cannot be verified."""
    off = verified_offsets()
    _REGISTRY[k.H_CAPACITY] = CAPACITY
    _REGISTRY[k.H_SPRING_BIT] = int(mujoco.mjtDisableBit.mjDSBL_SPRING)
    _REGISTRY[k.H_DAMPER_BIT] = int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
    _REGISTRY[k.H_DISABLEFLAGS] = off["disableflags"]
    for slot, name in [
        (k.H_SITE_XPOS, "site_xpos"), (k.H_SITE_XMAT, "site_xmat"), (k.H_XPOS, "xpos"), (k.H_XMAT, "xmat"),
        (k.H_CVEL, "cvel"), (k.H_SUBTREE_COM, "subtree_com"), (k.H_CDOF, "cdof"), (k.H_QFRC, "qfrc_passive"),
    ]:  # fmt: skip
        _REGISTRY[slot] = off[name]


def native_available() -> bool:
    """Whether the native dispatcher can be used with the installed MuJoCo."""
    if "available" not in _STATE["native"]:
        try:
            _native_header()
            _libmujoco()
            _STATE["native"]["available"] = True
        except (LayoutError, OSError) as exc:
            warnings.warn(f"mjflex: using the Python passive callback ({exc})", RuntimeWarning, stacklevel=3)
            _STATE["native"]["available"] = False
    return _STATE["native"]["available"]


def _c_function(function, argtypes, restype):
    function.argtypes, function.restype = argtypes, restype
    return function


def _native_callback(previous_address):
    """A ctypes function pointer to the native dispatcher (chaining a native previous callback).

    On a non-finite wrench, ``dispatch`` fills ``qfrc_passive`` with NaN and returns the
    element's message. In a thread that Python runs (``mj_step`` called through the bindings,
    which intercept MuJoCo errors) the dispatcher calls ``mju_error``: the step stops and
    ``mujoco.FatalError`` reaches the caller. In threads MuJoCo starts itself (``rollout``),
    where ``mju_error`` would end the process, it calls ``mju_warning`` instead and MuJoCo's
    own divergence handling (warning, auto-reset) takes over.
    """
    cache = _STATE["native"]
    if ("cb", previous_address) in cache:
        return cache[("cb", previous_address)][0]
    reg_addr = _REGISTRY.ctypes.data
    lib = _libmujoco()
    mju_error = _c_function(lib.mju_error, [ctypes.c_void_p], None)
    mju_warning = _c_function(lib.mju_warning, [ctypes.c_void_p], None)
    python_thread = _c_function(ctypes.pythonapi.PyGILState_GetThisThreadState, [], ctypes.c_void_p)
    previous = None if previous_address is None else _PROTO(previous_address)

    def report(msg):
        if k.int_from_voidptr(python_thread()) != 0:
            mju_error(k.voidptr_from_int(msg))
        else:
            mju_warning(k.voidptr_from_int(msg))

    if previous is None:

        def dispatcher(m, d):
            msg = k.dispatch(k.int_from_voidptr(m), k.int_from_voidptr(d), reg_addr)
            if msg != 0:
                report(msg)

    else:

        def dispatcher(m, d):
            previous(m, d)
            msg = k.dispatch(k.int_from_voidptr(m), k.int_from_voidptr(d), reg_addr)
            if msg != 0:
                report(msg)

    report = njit(report)
    compiled = cfunc(types.void(types.voidptr, types.voidptr), error_model="numpy")(dispatcher)
    pointer = _PROTO(compiled.address)
    cache[("cb", previous_address)] = (pointer, compiled)
    return pointer


def _python_dispatcher(m, d):
    previous = _STATE["previous"]
    if previous is not None:
        if isinstance(previous, ctypes._CFuncPtr):
            previous(m._address, d._address)
        else:
            previous(m, d)
    provider = _PROVIDERS.get(m._address)
    if provider is not None:
        provider._apply_in_callback(d)


def _is_ours(callback) -> bool:
    return callback is not None and callback is _STATE["callback"]


def _install_dispatcher():
    current = mujoco.get_mjcb_passive()
    if _is_ours(current):
        return
    _STATE["previous"] = current
    if (current is None or isinstance(current, ctypes._CFuncPtr)) and native_available():
        address = None if current is None else ctypes.cast(current, ctypes.c_void_p).value
        callback = _native_callback(address)
    else:
        callback = _python_dispatcher
    mujoco.set_mjcb_passive(callback)
    _STATE["callback"] = callback


def register(provider, slot_words) -> None:
    """Register ``provider`` (``slot_words``: its registry slot) and install the dispatcher."""
    address = provider.model._address
    other = _PROVIDERS.get(address)
    if other is not None and other is not provider:
        raise RuntimeError(
            "another mjflex.Flexures is installed for this model; call its uninstall() first (one provider per model)"
        )
    if other is None:
        count = int(_REGISTRY[k.H_COUNT])
        if count == CAPACITY:
            raise RuntimeError(f"mjflex can serve at most {CAPACITY} models at once; uninstall unused ones")
        at = k.HEADER + k.SLOT * count
        _REGISTRY[at + 1 : at + k.SLOT] = slot_words[1:]
        _REGISTRY[at + k.S_MODEL] = address
        _REGISTRY[k.H_COUNT] = count + 1  # last: the slot becomes visible complete
        _PROVIDERS[address] = provider
    _install_dispatcher()


def unregister(provider) -> None:
    """Remove ``provider``; restore the previous callback when no model is left."""
    address = provider.model._address
    if _PROVIDERS.get(address) is not provider:
        return
    slots = _REGISTRY[k.HEADER :].reshape(CAPACITY, k.SLOT)
    count = int(_REGISTRY[k.H_COUNT])
    i = int(np.nonzero(slots[:count, k.S_MODEL] == address)[0][0])
    slots[i] = slots[count - 1]  # keep the used slots contiguous (the dispatcher scans the first H_COUNT)
    slots[count - 1] = 0
    _REGISTRY[k.H_COUNT] = count - 1
    del _PROVIDERS[address]
    if not _PROVIDERS:
        if _is_ours(mujoco.get_mjcb_passive()):
            mujoco.set_mjcb_passive(_STATE["previous"])
        # else: the user replaced our callback meanwhile; theirs stays
        _STATE["callback"] = _STATE["previous"] = None


def is_installed(provider) -> bool:
    return _PROVIDERS.get(provider.model._address) is provider and _is_ours(mujoco.get_mjcb_passive())
