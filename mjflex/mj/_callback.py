"""The process-global ``mjcb_passive`` callback, shared by every :class:`mjflex.Flexures`.

MuJoCo has one passive callback per process, called for every model. mjflex installs one
dispatcher and keeps a registry of the models it serves (a provider's own model and the
copies it was asked to serve); every other model (including the temporary ones MuJoCo builds
while compiling) is left untouched.

Rules of the native dispatcher (a numba ``cfunc`` given to MuJoCo as a C function pointer)
-----------------------------------------------------------------------------------------
* It needs neither the GIL nor the Python bindings: compiling models while it is installed
  works (a Python callback makes ``mj_compile`` fail with "Python exception raised"), and
  ``mujoco.rollout`` and ``mujoco.batch.Batch`` threads run it.
* It allocates nothing and validates nothing: everything it reads (the element tables, the
  registry, the ``mjData`` offsets) was built and checked at installation. It finds the arrays of
  ``mjData`` through offsets verified at start-up (:mod:`._layout`); when the layout of the
  installed MuJoCo cannot be verified (``LayoutError``), the Python dispatcher below is used.
* Registry: a fixed block of int64 words (``CAPACITY`` slots). Installation and removal take
  ``_LOCK`` (several Python threads may install at once); slots never move, a slot is filled
  before its model word is written, and removal clears the model word first, so a dispatcher
  running in another thread for another model never reads a half-written slot. Do not install
  or uninstall a provider while another thread is stepping one of *its* models.
* The only thing it may do besides adding forces is report a diverging element (non-finite
  wrench, or one that alone would accelerate a body beyond MuJoCo's ``mjMAXVAL``): it fills
  ``qfrc_passive`` with NaN (so that MuJoCo's own checks see it) and reports the element's
  message, with the time and step, through MuJoCo:

  - ``mju_warning`` when MuJoCo's auto-reset is on (MuJoCo then warns and resets, as for its
    own divergences) or when the calling thread has no MuJoCo error handler (``mujoco.rollout``
    worker threads, where ``mju_error`` would end the process);
  - ``mju_error`` otherwise: ``mujoco.FatalError`` from ``mj_step``/``mj_forward`` called in
    Python, ``mujoco.batch.SimulationError`` naming the element from a ``Batch``.

  Whether a thread has an error handler is read from MuJoCo's thread-local log handler
  (``_mjPRIVATE_setTlsLogHandler``, set by the bindings, rollout and Batch around their calls);
  where that symbol is missing, a thread with a Python thread state counts as handled.

A Python dispatcher is used instead when a Python callback was already installed (it is
chained; MuJoCo then cannot compile models while installed, and ``Batch`` refuses Python
callbacks) or when the struct layout cannot be verified. It follows the same reporting rules.
"""

import ctypes
import os
import threading
import warnings

import llvmlite.binding as llvm
import mujoco
import numpy as np
from llvmlite import ir
from numba import cfunc, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from . import _kernels as k
from ._layout import LayoutError, verified_offsets

#: Most models (a provider's model and its served copies, over all providers) that one process
#: can serve at once; ``install`` raises beyond it.
CAPACITY = 1024
_REGISTRY = np.zeros(k.HEADER + k.SLOT * CAPACITY, dtype=np.int64)
_SLOTS = _REGISTRY[k.HEADER :].reshape(CAPACITY, k.SLOT)
_LOCK = threading.RLock()
_STACKS = {}  # model address -> [(provider, model), ...], the innermost installation last
_IN_SLOT = {}  # model address -> (slot, provider, model): the provider that serves it now
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
    _REGISTRY[k.H_AUTORESET_BIT] = int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    for word, name in [
        (k.H_DISABLEFLAGS, "disableflags"), (k.H_TIME, "time"), (k.H_TIMESTEP, "timestep"),
        (k.H_SITE_XPOS, "site_xpos"), (k.H_SITE_XMAT, "site_xmat"), (k.H_XPOS, "xpos"), (k.H_XMAT, "xmat"),
        (k.H_CVEL, "cvel"), (k.H_SUBTREE_COM, "subtree_com"), (k.H_CDOF, "cdof"), (k.H_QFRC, "qfrc_passive"),
    ]:  # fmt: skip
        _REGISTRY[word] = off[name]


def native_available() -> bool:
    """Whether the native dispatcher can be used with the installed MuJoCo."""
    with _LOCK:
        if "available" not in _STATE["native"]:
            try:
                _native_header()
                _libmujoco()
                _STATE["native"]["available"] = True
            except (LayoutError, OSError) as exc:
                warnings.warn(f"mjflex: using the Python passive callback ({exc})", RuntimeWarning, stacklevel=3)
                _STATE["native"]["available"] = False
        return _STATE["native"]["available"]


# --------------------------------------------------------------------------- reporting


def _address(lib, name):
    try:
        return ctypes.cast(getattr(lib, name), ctypes.c_void_p).value
    except AttributeError:
        return None


def _c_function(function, argtypes, restype):
    function.argtypes, function.restype = argtypes, restype
    return function


def _tls_probe(lib):
    """A ctypes function ``() -> bool``: whether this thread has a MuJoCo error handler, or None."""
    if _address(lib, "_mjPRIVATE_setTlsLogHandler") is None:
        return None
    return _c_function(lib._mjPRIVATE_setTlsLogHandler, [ctypes.c_void_p], ctypes.c_void_p)


def errors_caught_here() -> bool:
    """Whether ``mju_error`` in the calling thread would be caught (not end the process)."""
    lib = _libmujoco()
    probe = _tls_probe(lib)
    if probe is None:
        return ctypes.pythonapi.PyGILState_GetThisThreadState() is not None
    previous = probe(None)
    probe(previous)
    return previous is not None


def _variadic_call(symbol):
    """An intrinsic ``f(format, time, step)`` calling the printf-like C function ``symbol``."""

    @intrinsic
    def call(typingctx, fmt, time, step):
        def codegen(context, builder, signature, args):
            char_p = ir.IntType(8).as_pointer()
            fnty = ir.FunctionType(ir.VoidType(), [char_p], var_arg=True)
            fn = cgutils.get_or_insert_function(builder.module, fnty, symbol)
            builder.call(fn, [builder.bitcast(args[0], char_p), args[1], args[2]])
            return context.get_dummy_value()

        return types.void(types.voidptr, types.float64, types.float64), codegen

    return call


def _native_callback(previous_address):
    """A ctypes function pointer to the native dispatcher (chaining a native previous callback)."""
    cache = _STATE["native"]
    if ("cb", previous_address) in cache:
        return cache[("cb", previous_address)][0]
    reg_addr = _REGISTRY.ctypes.data
    lib = _libmujoco()
    for name in ("mju_error", "mju_warning"):
        llvm.add_symbol(name, _address(lib, name))
    error_t, warning_t = _variadic_call("mju_error"), _variadic_call("mju_warning")
    tls = _tls_probe(lib)
    python_thread = _c_function(ctypes.pythonapi.PyGILState_GetThisThreadState, [], ctypes.c_void_p)
    previous = None if previous_address is None else _PROTO(previous_address)

    if tls is None:

        def caught():
            return k.int_from_voidptr(python_thread()) != 0
    else:

        def caught():
            handler = tls(k.voidptr_from_int(0))
            tls(handler)
            return k.int_from_voidptr(handler) != 0

    caught = njit(caught)

    def report(m, d, msg):
        time, autoreset, step = k.report_context(m, d, reg_addr)
        if autoreset or not caught():
            warning_t(k.voidptr_from_int(msg), time, step)
        else:
            error_t(k.voidptr_from_int(msg), time, step)

    report = njit(report)

    if previous is None:

        def dispatcher(m, d):
            msg = k.dispatch(k.int_from_voidptr(m), k.int_from_voidptr(d), reg_addr)
            if msg != 0:
                report(k.int_from_voidptr(m), k.int_from_voidptr(d), msg)

    else:

        def dispatcher(m, d):
            previous(m, d)
            msg = k.dispatch(k.int_from_voidptr(m), k.int_from_voidptr(d), reg_addr)
            if msg != 0:
                report(k.int_from_voidptr(m), k.int_from_voidptr(d), msg)

    compiled = cfunc(types.void(types.voidptr, types.voidptr), error_model="numpy")(dispatcher)
    pointer = _PROTO(compiled.address)
    cache[("cb", previous_address)] = (pointer, compiled)
    return pointer


def message_text(model, data, message: bytes) -> str:
    """An element's divergence message (a printf format of time and step) for ``data``."""
    step = data.time / model.opt.timestep if model.opt.timestep > 0 else 0.0
    return message[:-1].decode() % (data.time, step)


def report_in_python(model, data, message: bytes) -> None:
    """The Python dispatcher's report of a diverging element, by the same rules as the native one."""
    text = message_text(model, data, message)
    autoreset = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_AUTORESET
    if autoreset or not errors_caught_here():
        warning = _c_function(_libmujoco().mju_warning, [ctypes.c_char_p], None)
        warning(text.replace("%", "%%").encode())  # mju_warning takes a printf format
    else:
        raise mujoco.FatalError(text)


def _python_dispatcher(m, d):
    previous = _STATE["previous"]
    if previous is not None:
        if isinstance(previous, ctypes._CFuncPtr):
            previous(m._address, d._address)
        else:
            previous(m, d)
    served = _IN_SLOT.get(m._address)
    if served is not None:
        served[1]._apply_in_callback(m, d)


# --------------------------------------------------------------------------- installation


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


def _restore_dispatcher():
    if _is_ours(mujoco.get_mjcb_passive()):
        mujoco.set_mjcb_passive(_STATE["previous"])
    # else: the user replaced our callback meanwhile; theirs stays
    _STATE["callback"] = _STATE["previous"] = None


def _publish(model, provider):
    """Give ``model`` a slot served by ``provider`` (the old slot, if any, is cleared after)."""
    free = np.flatnonzero(_SLOTS[:CAPACITY, k.S_MODEL] == 0)
    if free.size == 0:
        raise RuntimeError(
            f"mjflex serves at most {CAPACITY} models per process at once (mjflex.mj._callback.CAPACITY); "
            "uninstall providers you no longer step, serve identical copies through one model "
            "(Batch.set_models(model)), or spread the work over processes"
        )
    slot = int(free[0])
    _SLOTS[slot, 1:] = provider._slot_words(model)[1:]
    _SLOTS[slot, k.S_MODEL] = model._address  # last: the slot becomes visible complete
    _REGISTRY[k.H_USED] = max(int(_REGISTRY[k.H_USED]), slot + 1)
    old = _IN_SLOT.get(model._address)
    _IN_SLOT[model._address] = (slot, provider, model)
    if old is not None:
        _clear(old[0])


def _clear(slot):
    _SLOTS[slot, k.S_MODEL] = 0  # first: no dispatcher matches the slot any more
    used = int(_REGISTRY[k.H_USED])
    while used > 0 and _SLOTS[used - 1, k.S_MODEL] == 0:
        used -= 1
    _REGISTRY[k.H_USED] = used


def register(provider, models) -> None:
    """Serve ``models`` with ``provider`` (innermost installation wins) and install the dispatcher."""
    with _LOCK:
        done = []
        try:
            for model in models:
                stack = _STACKS.setdefault(model._address, [])
                stack.append((provider, model))
                done.append(model)
                _publish(model, provider)
        except BaseException:
            _remove(provider, done)
            raise
        _install_dispatcher()


def _remove(provider, models):
    for model in models:
        stack = _STACKS.get(model._address, [])
        for i in range(len(stack) - 1, -1, -1):
            if stack[i][0] is provider:
                del stack[i]
                break
        served = _IN_SLOT.get(model._address)
        if served is not None and served[1] is provider:
            if stack:
                _publish(stack[-1][1], stack[-1][0])
            else:
                del _IN_SLOT[model._address]
                _clear(served[0])
        if not stack:
            _STACKS.pop(model._address, None)


def unregister(provider, models) -> None:
    """Stop serving ``models`` with ``provider``; an outer installation of the same models takes over.

    When no model is left, the passive callback that was there before is restored.
    """
    with _LOCK:
        _remove(provider, models)
        if not _IN_SLOT and _STATE["callback"] is not None:
            _restore_dispatcher()


def serving(model):
    """The provider that serves ``model`` now, or None."""
    served = _IN_SLOT.get(model._address)
    return None if served is None else served[1]


def models_served() -> int:
    """How many models the registry serves now (at most :data:`CAPACITY` per process)."""
    with _LOCK:
        return len(_IN_SLOT)


def dispatcher_installed() -> bool:
    return _is_ours(mujoco.get_mjcb_passive())


def uninstall_all() -> None:
    """Uninstall every provider of the process (for tests and interactive sessions)."""
    with _LOCK:
        providers = {id(p): p for stack in _STACKS.values() for p, _ in stack}
        for provider in providers.values():
            while provider._depth:
                provider.uninstall()
