"""The speed-accuracy trade of simulating a model's flexures, measured on the user's own scene.

``study(model)`` (``python -m mjflex study MODEL.xml``) runs the model from its initial state
(its first keyframe, or ``keyframe=``/``qpos=``/``qvel=``) and

1. builds a **reference**: RK4 at the model's time step, halved until two successive runs agree
   to ``reference_tol`` in the pose error below (the achieved agreement and the reference's
   estimated error, agreement / 15 for a 4th-order method, are reported);
2. sweeps **candidates**: element method (twist, dual quaternion) x MuJoCo integrator (RK4,
   Euler, implicitfast, discrete) x time step (log-spaced from past the stability limit
   down, every step a divisor of the sample interval so all runs are compared at the same
   times) x model **variants** (:data:`mjflex.app.study.variants.DEFAULT_VARIANTS` or
   ``variants=``: :class:`mjflex.variants.variant.Variant` objects or builders);
3. measures for each: seconds of ``mj_step`` per simulated second (median of ``repeat``
   timings in this process, interleaved across candidates so that the load of a shared machine
   spreads evenly; wall and thread CPU time, ranked by ``clock``), the error against the
   reference in the poses of the tracked bodies or sites (relative to the motion), in energy
   and in the first natural frequencies, and, per (variant, method, integrator), the largest
   stable step by bisection between the largest stable and smallest diverged grid steps;
4. returns a :class:`StudyResult` (rows, limits, Pareto front, recommendation) and, with
   ``out=``, writes ``study_<model>.md``, ``.json`` and the Pareto plot ``.png`` there.

Divergence is detected (NaN, MuJoCo's bad-state warnings, mjflex's non-finite-wrench error,
energy leaving the reference's range), reported with the step, the time and the element, and
never enters the table as a result; MuJoCo's automatic reset is switched off on the study's
model copies so that a blown-up run cannot restart silently.

Errors, all relative: **pose** = the larger of the position error (largest distance of a tracked
item from its reference position, over the largest displacement of any tracked item in the
reference) and the rotation error (likewise with angles); **energy** = largest deviation of the
total energy (MuJoCo's kinetic and potential energy plus the elements' elastic energy) from the
reference's, over the reference's largest kinetic or elastic energy swing; **frequency** =
largest relative difference of the first ``frequencies`` elastic natural frequencies of the
linearized model (about the initial ``qpos`` at rest) from the full model's. Poses are taken in
the frame of ``frame``: by default the heaviest body of a free-floating mechanism (so the errors
measure deformation, not the rigid motion of the whole) or the world for a grounded one.

Parameters
----------
model : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
    MJCF path, spec or compiled model, with mjflex elements.
keyframe : str or int, optional
    Initial state (default: the first keyframe).
qpos, qvel : array_like, shape (nq,) and (nv,), optional
    Initial positions and velocities; they override the keyframe's.
duration : float, optional
    Simulated time [s]; default one period of the lowest elastic mode (within 200 and 20000 of
    the model's steps), rounded to whole sample intervals.
track : list of str, optional
    Bodies or sites whose poses are compared (default: every named body but the frame).
frame : str
    Body the poses are taken in, ``"world"`` or ``"auto"``.
methods, integrators : sequence of str
    Candidate element methods and MuJoCo integrators.
steps : sequence of float, optional
    Candidate time steps [s]; by default ``step_count`` log-spaced steps from ``max_step``
    down by factors of 2. Steps are rounded to divisors of the sample interval.
step_count : int
    Number of default steps (without ``steps``).
max_step, min_step : float, optional
    Largest and smallest default step [s] (without ``steps``); ``max_step`` defaults to twice
    RK4's limit for the highest natural frequency of the linearized model, damping included.
variants : list, optional
    Variants or builders ``source -> Variant`` to compare, a builder being called with ``model``
    as given (default :data:`~mjflex.app.study.variants.DEFAULT_VARIANTS`).
repeat : int
    Interleaved timing rounds (median reported).
bisect : int
    Most bisection runs per stability limit: first over divisors of the sample interval (full
    candidates, with errors), then over any step (divergence only) until the bracket is within
    ``limit_rtol`` (relative). 0: no bisection, the limits are bracketed by the grid steps.
limit_rtol : float
    Relative width of the bracket at which the bisection of a stability limit stops.
reference_tol : float
    Agreement (relative pose error) of two successive reference refinements that stops them,
    in (0, 1).
max_refinements : int
    Most halvings of the reference step.
reference_step : float, optional
    First step of the reference [s] (default: the model's own step).
frequencies : int
    How many elastic natural frequencies enter the frequency error.
samples : int
    Sample intervals over the duration (upper bound of the sample interval: ``duration/samples``).
max_run_wall : float
    Wall-time budget of one run [s]; a run projected to exceed it stops and is marked skipped.
targets : sequence of float
    Pose-error targets of the recommendation (relative, each in (0, 1]: 0.01 is 1 %).
clock : {"cpu", "wall"}
    What the cost is ranked by: the stepping thread's CPU time (default: on an idle core it is
    the wall time, and other processes of a shared machine do not inflate it) or the wall time.
    Both are recorded.
out : str, optional
    Directory to write the report files to, created if missing (the set is replaced together;
    a study that stops after its runs began writes ``study_<model>.partial.*`` instead, beside
    earlier results, which it leaves as they were).
progress : bool
    Show a progress bar (tqdm) on stderr.

Returns
-------
StudyResult
    Everything measured (:class:`mjflex.app.study.StudyResult`): ``rows``, one
    :class:`~mjflex.app.study.Row` per candidate (variant, method, integrator, step, status, cost,
    pose, energy and frequency errors, divergence); ``limits``, one :class:`~mjflex.app.study.Limit`
    per variant, method and integrator (the measured and the advised stability limit, the mode that
    sets it, the step to use); ``reference`` (:class:`~mjflex.app.study.Reference`); the natural
    frequencies and the variants' reports. ``recommendation()`` and ``needs()`` choose;
    ``to_markdown()``, ``records()`` (for pandas) and ``write(dir)`` report. A study that cannot
    start, or whose reference diverges, raises instead (below).

Raises
------
StudyError
    An option out of range, a model without elements, no initial state that moves, a name given
    (keyframe, track, frame) that the model lacks: all found before anything runs or is written
    (``exc.partial`` is None). Or the reference diverges at every step: ``exc.partial`` holds
    what was measured and, with ``out``, it has been written as ``study_<model>.partial.*``.
TypeError
    An option of the wrong type (e.g. ``repeat=2.5``, ``track="body"`` instead of a list).

Examples
--------
A block on a leaf spring, pushed into a rocking motion: two integrators at two steps, one element method, no
model variants, one timing round and no bisection (seconds; the defaults take longer). Costs are measured, so
they vary from run to run; the errors do not:

{study_example}
>>> result.reference.converged, [(row.integrator, row.timestep) for row in result.rows]
(True, [('rk4', 0.0002), ('rk4', 0.0001), ('euler', 0.0002), ('euler', 0.0001)])
>>> print(", ".join(f"{row.integrator} {row.timestep:g} s: {row.pose_error:.0e}" for row in result.rows))
rk4 0.0002 s: 2e-05, rk4 0.0001 s: 2e-06, euler 0.0002 s: 1e-02, euler 0.0001 s: 4e-03

``result.recommendation()`` names the cheapest candidate for each error target, ``result.write("out")`` writes
the report.
"""

from ._options import check_options
from ._result import StudyResult
from ._rows import Limit, Reference, Row, with_study_example
from ._scene import StudyError
from ._sweep import INTEGRATORS, METHODS, study
from .variants import DEFAULT_VARIANTS

study.__doc__ = __doc__  # the function's reference (help(mjflex.study), the API pages) is this docstring
__doc__ = with_study_example(study).__doc__

__all__ = [
    "DEFAULT_VARIANTS",
    "INTEGRATORS",
    "METHODS",
    "Limit",
    "Reference",
    "Row",
    "StudyError",
    "StudyResult",
    "check_options",
    "study",
]
