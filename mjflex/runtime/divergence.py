"""How mjflex reports a diverging element, and the one convention for times and steps in its messages.

Forces at a finite state
------------------------
At any finite state the elements' forces are finite and exact, in every call: ``mj_forward``,
``mj_inverse``, ``mj_step``, rollouts, :class:`mjflex.Flexures`' queries. A large wrench is never
an error by itself (``mj_forward`` / ``mj_inverse`` serve statics and linearization at large
deflections of light bodies). Divergence is judged where MuJoCo judges it: in the step.

What counts as divergence
-------------------------
* A non-finite wrench (a NaN or infinite state, or forces beyond float64): ``qfrc_passive`` is
  set to NaN so that MuJoCo's own checks see it, and the element is reported at once.
* A step that MuJoCo finds bad (its ``mj_checkPos`` / ``mj_checkVel`` / ``mj_checkAcc``: a NaN
  or a value beyond ``mjMAXVAL`` = 1e10 in ``qpos``, ``qvel`` or ``qacc``): mjflex blames the
  element whose force alone accelerated one of its bodies the most in that step, if that
  acceleration exceeded a hundredth of ``mjMAXVAL`` (the body's mass and smallest principal inertia
  turn the element's force and moment into accelerations). The engine plugin reports it within
  that step (its ``advance``, which MuJoCo calls at the end of every step); the ``mjcb_passive``
  provider at its next evaluation (the next ``mj_forward``, RK4 stage or step). When no element
  was that violent, MuJoCo's own warning stands alone.

Where the report goes
---------------------
Through MuJoCo, as its own bad-state messages: ``mju_warning`` when MuJoCo's auto-reset is on (its
default; MuJoCo then warns and resets), or in a thread without an error handler
(``mujoco.rollout``'s workers, where an error would end the process); ``mju_error`` with auto-reset
off otherwise: ``mujoco.FatalError`` from ``mj_step`` / ``mj_forward`` called in Python,
``mujoco.batch.SimulationError`` naming the element from a ``Batch``.

Once per element per run
------------------------
A *run* is an ``MjData`` from its creation, or from the user's ``mj_resetData`` /
``mj_resetDataKeyframe``, to the next such reset. MuJoCo's automatic resets after a bad state do
not start a new run: they are what makes a diverging model diverge again and again. The first
divergence of an element in a run is printed; the repeats are counted, not printed
(:meth:`mjflex.Flexures.divergences` reads the counts). Errors (auto-reset off) are raised every
time: each stops the call. This matches MuJoCo, which prints each bad-state warning once per
``MjData`` until ``mj_resetData``. Two caveats: a ``mujoco.batch.Batch`` that is not
``persistent`` runs many simulations on one ``MjData`` per thread, so counts there are per thread
(the engine plugin) or approximate (the callback); and the callback keeps its records for at most
64 ``MjData`` of one model at once (the least recently used is forgotten).

A Python warning beside the log line
------------------------------------
Importing mjflex puts a log handler in front of MuJoCo's (``mju_setLogHandler``, MuJoCo 4's
structured log): every message goes on to the handler that was there (MuJoCo's console and
``MUJOCO_LOG.TXT``, or a legacy ``mju_user_warning`` someone set), unchanged; an mjflex divergence
report also raises a :class:`DivergenceWarning` in Python, with the element, the model, the time
and the step as attributes. It comes from the same report, so it follows the same rule: once per
element and run, in both element forms, and the repeats are counted, not warned. The handler runs
only when MuJoCo logs something (never per step), takes the GIL for that message only, and never
lets a Python exception unwind through MuJoCo's C code (an ``"error"`` warnings filter cannot turn
this warning into an exception there: disable MuJoCo's auto-reset for a ``mujoco.FatalError``
instead). :func:`divergence_warnings` takes the handler out (or puts it back); it is taken out at
interpreter exit.

Times and steps
---------------
Every mjflex message names a step the same way: ``the step from t = 0.001 s (step index 1,
counting from 0)``: the step that *starts* at ``t``, whose index ``k = round(t / h)`` counts
whole time steps ``h`` from ``t = 0`` (:func:`step_phrase`). The provider, the sweep, the study
and the command line all use it.
"""

import atexit
import ctypes
import functools
import os
import re
import threading
import warnings
from dataclasses import dataclass

import mujoco
import numpy as np

from ..native import library

__all__ = ["Divergence", "DivergenceWarning", "divergence_warnings", "step_index", "step_phrase"]


def step_index(t: float, h: float) -> int:
    """Index (from 0) of the step that starts at time ``t`` with time step ``h``."""
    return int(np.rint(t / h)) if h > 0 and np.isfinite(t) else 0


def step_phrase(t: float, h: float) -> str:
    """``"the step from t = ... s (step index k, counting from 0)"``: the convention of every mjflex message."""
    return f"the step from t = {t:.9g} s (step index {step_index(t, h)}, counting from 0)"


@dataclass(frozen=True)
class Divergence:
    """The divergences of one element in one run of an ``MjData`` (:meth:`mjflex.Flexures.divergences`).

    ``count``: how many (the first and its repeats); ``time``: the start of the step of the first
    [s]; ``step``: that step's index (from 0); ``message``: the text that reported the first.
    ``pending``: the last one is found but not yet reported (the ``mjcb_passive`` provider
    reports a bad step at its next evaluation).
    """

    element: str
    count: int
    time: float
    step: int
    message: str
    pending: bool = False


class DivergenceWarning(RuntimeWarning):
    """An mjflex element diverged: raised beside MuJoCo's log line of the report, once per element and run.

    Attributes (from the report): ``element``, ``model`` (names), ``time`` [s] (the start of the
    step), ``step`` (its index from 0); the message is the report's text.

    Examples
    --------
    A 1e7 N/m element on a 0.5 kg block stepped at 10 ms (Euler's limit is 0.4 ms):

    >>> import warnings
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco model="block"><option timestep="0.01" gravity="0 0 0"/><worldbody><body name="B"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "B", pos=[0, 0, 0], K=[2e3, 2e3, 1e3, 1e7, 1e7, 1e7])
    >>> model = spec.compile()
    >>> data = mujoco.MjData(model)
    >>> data.qvel[0] = 1.0
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     mujoco.mj_step(model, data, nstep=20)  # MuJoCo's log prints the report; Python gets the warning too
    >>> found = [w.message for w in caught if w.category is mjflex.DivergenceWarning]
    >>> len(found), found[0].element, found[0].model, found[0].step
    (1, 'leaf', 'block', 3)
    """

    def __init__(self, message: str):
        super().__init__(message)
        match = _REPORT.match(message)
        self.element = match["element"] if match else ""
        self.model = match["model"] if match else ""
        self.time = float(match["time"]) if match else float("nan")
        self.step = int(match["step"]) if match else -1


_REPORT = re.compile(
    r"mjflex: flexure '(?P<element>.*?)' of model '(?P<model>.*?)' diverged in the step from "
    r"t = (?P<time>\S+) s \(step index (?P<step>\d+)"
)


class _LogMessage(ctypes.Structure):  # mjLogMessage of mjtype.h (MuJoCo 4.0)
    _fields_ = (
        ("level", ctypes.c_int),
        ("topic", ctypes.c_int),
        ("subject", ctypes.c_char * 1024),
        ("body", ctypes.c_char_p),
        ("func", ctypes.c_char_p),
        ("file", ctypes.c_char_p),
        ("line", ctypes.c_int),
        ("timestamp", ctypes.c_ubyte),
    )


_HANDLER = ctypes.CFUNCTYPE(None, ctypes.POINTER(_LogMessage))
_LOG = {"ours": None, "previous": None, "lock": threading.Lock()}


@functools.cache
def mujoco_library():
    """MuJoCo's own library (ctypes), for ``mju_setLogHandler`` and ``mju_warning``."""
    folder = os.path.dirname(mujoco.__file__)
    names = sorted(f for f in os.listdir(folder) if f.startswith(("libmujoco.so", "libmujoco.", "mujoco.dll")))
    lib = ctypes.CDLL(os.path.join(folder, names[0]))
    lib.mju_setLogHandler.argtypes, lib.mju_setLogHandler.restype = [ctypes.c_void_p], ctypes.c_void_p
    lib.mju_warning.argtypes, lib.mju_warning.restype = [ctypes.c_char_p, ctypes.c_char_p], None
    return lib


def _on_log(message):
    """MuJoCo's log handler: pass the message on, then warn in Python for an mjflex divergence report."""
    try:
        previous = _LOG["previous"]
        if previous is not None:
            previous(message)
        text = message.contents.subject.decode(errors="replace")
        if message.contents.level >= int(mujoco.mjtLogLevel.mjLOG_WARNING) and _REPORT.match(text):
            warnings.warn(DivergenceWarning(text), stacklevel=2)
    except BaseException:
        pass


def divergence_warnings(enabled: bool = True) -> bool:
    """Raise :class:`DivergenceWarning` beside mjflex's divergence reports (``enabled``), or stop; returns the
    previous setting.

    On by default from ``import mjflex``: a log handler in front of MuJoCo's passes every message
    on unchanged and warns in Python for mjflex's reports (module docstring). Off puts MuJoCo's
    previous handler back.

    Parameters
    ----------
    enabled : bool
        Whether the warnings are raised.

    Returns
    -------
    bool
        Whether they were raised before the call.

    Examples
    --------
    >>> import mjflex
    >>> mjflex.divergence_warnings(False)  # the log lines only, as MuJoCo prints them
    True
    >>> mjflex.divergence_warnings(True)
    False
    """
    with _LOG["lock"]:
        was = _LOG["ours"] is not None
        if enabled and not was:
            lib = mujoco_library()
            ours = _HANDLER(_on_log)
            previous = lib.mju_setLogHandler(ctypes.cast(ours, ctypes.c_void_p))
            _LOG["previous"] = _HANDLER(previous) if previous else None
            _LOG["ours"] = ours
        elif not enabled and was:
            previous = _LOG["previous"]
            mujoco_library().mju_setLogHandler(ctypes.cast(previous, ctypes.c_void_p) if previous is not None else None)
            _LOG["ours"] = None
        return was


divergence_warnings(True)
atexit.register(divergence_warnings, False)  # no Python callback left in MuJoCo once the interpreter goes


def model_name(model) -> str:
    return model.names[: model.names.index(b"\x00")].decode() or "unnamed"


def divergences_of(m, data, names, served, watches) -> dict[str, Divergence]:
    """:meth:`mjflex.Flexures.divergences`, read from the native watches of ``data`` (the plugin's, and the registry's
    in the buffer ``watches`` or None): ``names`` of the elements of model ``m``, its first ``served`` text records."""
    native, out = library.lib(), {}
    h = m.opt.timestep
    watches = (
        ("plugin", native.mjfx_plugin_watch(m._address, data._address)),
        ("record", None if watches is None else native.mjfx_registry_watch(watches.ctypes.data, served,
                                                                           data._address)),
    )  # fmt: skip
    for source, watch in watches:
        if not watch:
            continue
        # the plugin's tallies follow its table: the instances in order, as the plugin elements come after the records
        index = dict(enumerate(range(served, len(names)))) if source == "plugin" else None
        for i in range(native.mjfx_watch_size_of(watch)):
            e = index.get(i) if index is not None else (i if i < served else None)
            v = library.Verdict()
            count = native.mjfx_watch_first(watch, i, ctypes.byref(v))
            if e is None or count == 0:
                continue
            text = library.report_text(m, v, names[e])
            out[names[e]] = Divergence(names[e], count, v.step, step_index(v.step, h), text)
        pending = library.Verdict()
        native.mjfx_watch_peek(watch, m._address, data._address, ctypes.byref(pending))
        e = pending.element if index is None else index.get(pending.element)
        if pending.element >= 0 and e is not None and e < len(names):
            name, old = names[e], out.get(names[e])
            text = old.message if old else library.report_text(m, pending, name)
            first = (pending.step, step_index(pending.step, h)) if old is None else (old.time, old.step)
            out[name] = Divergence(name, (old.count if old else 0) + 1, *first, text, pending=True)
    return out
