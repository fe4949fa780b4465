"""The process-global ``mjcb_passive`` provider for text-record models, shared by every :class:`mjflex.Flexures`.

MuJoCo has one passive callback per process, called for every model. mjflex installs one
dispatcher and keeps a registry of the models it serves (a provider's own model and the copies it
was asked to serve); every other model (including the temporary ones MuJoCo builds while
compiling) is left untouched. Elements written as engine-plugin instances need none of this: their
forces belong to the model.

The native dispatcher (``mjfx_passive`` in ``mjflex/native/callback.c``)
------------------------------------------------------------------------
* A C function: it needs neither the GIL nor the Python bindings, so compiling models while it
  is installed works (a Python callback makes ``mj_compile`` fail with "Python exception
  raised"), and ``mujoco.rollout`` and ``mujoco.batch.Batch`` threads run it.
* It allocates nothing and validates nothing: the element tables it reads were built and checked
  when the provider was built; it reads ``mjData`` through the MuJoCo headers it was compiled
  against (the version is checked when the library loads).
* Registry: ``CAPACITY`` slots in C. Installation and removal take ``_LOCK`` (several Python
  threads may install at once); a slot is filled before its model pointer is written, and removal
  clears the pointer first, so a dispatcher running in another thread for another model never
  reads a half-written slot. Do not install or uninstall a provider while another thread is
  stepping one of *its* models. A previous C callback is chained (called first).
* Divergence (the rules of :class:`mjflex.Flexures`, "Divergence"): it fills ``qfrc_passive``
  with NaN only when an element's wrench is not finite, and reports an element through MuJoCo
  (``mju_warning``, or ``mju_error`` with auto-reset off in a thread with an error handler). Per
  ``mjData`` it keeps a small watch entry (``MJFX_WATCHES`` per model, keyed by the data's
  address, the least recently used reclaimed), which is how a diverging element is reported
  once per run with a count of the repeats.

A Python dispatcher is used instead when a Python callback was already installed (it is chained;
MuJoCo then cannot compile models while installed, and ``Batch`` refuses Python callbacks). It
calls the same C code (``mjfx_dispatch``) and follows the same reporting rules.
"""

import ctypes
import threading
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from ..native import library
from .divergence import mujoco_library

#: Most models (a provider's model and its served copies, over all providers) that one process
#: can serve at once; ``install`` raises beyond it (the native registry's ``MJFX_CAPACITY``).
CAPACITY = 1024
#: Held while a provider installs, uninstalls or changes the models it serves (several Python threads may).
LOCK = threading.RLock()
_STACKS = {}  # model address -> [(provider, model, Served), ...], the innermost installation last
_IN_SLOT = {}  # model address -> (slot, provider, model, buffers kept alive while published, Served)
_FREE = list(range(CAPACITY))  # free slots, the lowest first
_STATE = {"callback": None, "previous": None, "native_pointer": None}
_PROTO = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)


@dataclass(frozen=True)
class Served:
    """What a provider gives the registry to serve its text-record elements: their names (the first
    ``tables.served`` of ``names``), its element table, and ``watches_for(model)``, the buffer of the
    per-mjData divergence watches of a model (the provider keeps it across installs: a run outlives them)."""

    names: tuple
    tables: object  # mjflex.runtime.tables.Tables
    watches_for: Callable


# --------------------------------------------------------------------------- reporting


def report_in_python(model, text: str, first: bool) -> None:
    """The Python dispatcher's report, by the native rules: raise (auto-reset off and an error handler in this
    thread: ``mjfx_report_raises``), warn (a first divergence), or count only."""
    if library.lib().mjfx_report_raises(model._address):
        raise mujoco.FatalError(text)
    if first:  # MuJoCo's warning handler, as for its own bad-state warnings
        mujoco_library().mju_warning(b"%s", text.encode())


def _python_dispatcher(m, d):
    previous = _STATE["previous"]
    if previous is not None:
        if isinstance(previous, ctypes._CFuncPtr):
            previous(m._address, d._address)
        else:
            previous(m, d)
    served = _IN_SLOT.get(m._address)
    if served is None:
        return
    names, native = served[4].names, library.lib()
    verdicts = (library.Verdict * 2)()
    native.mjfx_dispatch(m._address, d._address, 0, ctypes.byref(verdicts))
    for v in verdicts:
        if v.element >= 0:
            report_in_python(m, library.report_text(m, v, names[v.element]), bool(v.first))


# --------------------------------------------------------------------------- installation


def _is_ours(callback) -> bool:
    return callback is not None and callback is _STATE["callback"]


def _install_dispatcher():
    current = mujoco.get_mjcb_passive()
    if _is_ours(current):
        return
    _STATE["previous"] = current
    native = library.lib()
    if native.mjfx_registry_capacity() != CAPACITY:
        raise RuntimeError("mjflex: the native registry's capacity differs from registry.CAPACITY; rebuild mjflex")
    if current is None or isinstance(current, ctypes._CFuncPtr):
        native.mjfx_set_previous(None if current is None else ctypes.cast(current, ctypes.c_void_p).value)
        if _STATE["native_pointer"] is None:
            _STATE["native_pointer"] = _PROTO(ctypes.cast(native.mjfx_passive, ctypes.c_void_p).value)
        callback = _STATE["native_pointer"]
    else:
        native.mjfx_set_previous(None)
        callback = _python_dispatcher
    mujoco.set_mjcb_passive(callback)
    _STATE["callback"] = callback


def _publish(model, provider, served):
    """Give ``model`` a slot served by ``provider`` (the old slot, if any, is cleared after)."""
    if not _FREE:
        raise RuntimeError(
            f"mjflex serves at most {CAPACITY} models per process at once (mjflex.runtime.registry.CAPACITY); "
            "uninstall providers you no longer step, serve identical copies through one model "
            "(Batch.set_models(model)), or spread the work over processes (or write the elements as "
            "mjflex.flexure plugin instances, whose forces need no registry)"
        )
    slot = _FREE.pop(0)
    t, n = served.tables, served.tables.served
    names = (ctypes.c_char_p * max(n, 1))(*(name.encode() for name in served.names[:n]))
    watches = served.watches_for(model)
    snapshot = np.zeros(library.lib().mjfx_snapshot_size(model._address) + 1, np.uint8)  # C writes the model's
    if library.lib().mjfx_registry_publish(
        slot, model._address, n, t.elements.ctypes.data, t.chain.ctypes.data, len(t.chain), t.exps.ctypes.data,
        t.coefs.ctypes.data, len(t.coefs), ctypes.cast(names, ctypes.c_void_p), watches.ctypes.data,
        snapshot.ctypes.data,
    ):  # fmt: skip
        _FREE.insert(0, slot)
        raise RuntimeError("mjflex: the element table does not fit the model (an index out of range); rebuild it")
    keep = (t, names, watches, snapshot)
    old = _IN_SLOT.get(model._address)
    _IN_SLOT[model._address] = (slot, provider, model, keep, served)
    if old is not None:
        _clear(old[0])


def _clear(slot):
    library.lib().mjfx_registry_clear(slot)  # the model pointer first: no dispatcher matches the slot any more
    _FREE.append(slot)
    _FREE.sort()


def register(provider, models, served: Served) -> None:
    """Serve ``models`` with ``provider``'s elements ``served`` (the innermost installation wins)."""
    with LOCK:
        done = []
        try:
            for model in models:
                stack = _STACKS.setdefault(model._address, [])
                stack.append((provider, model, served))
                done.append(model)
                _publish(model, provider, served)
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
                _publish(stack[-1][1], stack[-1][0], stack[-1][2])
            else:
                del _IN_SLOT[model._address]
                _clear(served[0])
        if not stack:
            _STACKS.pop(model._address, None)


def unregister(provider, models) -> None:
    """Stop serving ``models`` with ``provider``; an outer installation of the same models takes over.

    When no model is left, the passive callback that was there before is restored.
    """
    with LOCK:
        _remove(provider, models)
        if not _IN_SLOT and _STATE["callback"] is not None:  # the callback that was there before comes back
            if _is_ours(mujoco.get_mjcb_passive()):  # (unless the user replaced ours meanwhile: theirs stays)
                mujoco.set_mjcb_passive(_STATE["previous"])
            _STATE["callback"] = _STATE["previous"] = None
            library.lib().mjfx_set_previous(None)


def serving(model):
    """The provider that serves ``model`` now, or None."""
    served = _IN_SLOT.get(model._address)
    return None if served is None else served[1]


def models_served() -> int:
    """How many models the registry serves now (at most :data:`CAPACITY` per process)."""
    with LOCK:
        return len(_IN_SLOT)


def slots_in_use() -> int:
    """How many registry slots are in use (the native registry's count)."""
    return library.lib().mjfx_registry_used()


def dispatcher_installed() -> bool:
    return _is_ours(mujoco.get_mjcb_passive())


def uninstall_all() -> None:
    """Uninstall every provider of the process (for tests and interactive sessions)."""
    with LOCK:
        providers = {id(p): p for stack in _STACKS.values() for p, _, _ in stack}
        for provider in providers.values():
            for _ in range(100_000):  # one uninstall per install: the last one unregisters it
                if not any(p is provider for stack in _STACKS.values() for p, _, _ in stack):
                    break
                provider.uninstall()
