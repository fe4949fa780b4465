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

Times and steps
---------------
Every mjflex message names a step the same way: ``the step from t = 0.001 s (step index 1,
counting from 0)``: the step that *starts* at ``t``, whose index ``k = round(t / h)`` counts
whole time steps ``h`` from ``t = 0`` (:func:`step_phrase`). The provider, the sweep, the study
and the command line all use it.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Divergence", "step_index", "step_phrase"]


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
