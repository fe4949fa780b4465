"""The study's rows: a candidate's measurements (:class:`Row`), a stability limit (:class:`Limit`) and the reference
run (:class:`Reference`), each with its text and dict forms (:mod:`._result` gathers them)."""

import math
from dataclasses import asdict, dataclass, field

from ...core.docstrings import with_shared_docstring
from ._options import who
from ._run import Divergence
from ._stability import PERTURBATION

#: The opening of the study's examples (:func:`mjflex.study`, :class:`Row`, :class:`Limit`, :class:`Reference`,
#: :class:`StudyResult`): a block on a leaf spring, pushed into a rocking motion, studied with one element method and
#: two integrators at two steps. Their docstrings hold the line ``{study_example}`` in its place.
EXAMPLE = """\
>>> import mujoco
>>> import mjflex
>>> spec = mujoco.MjSpec.from_string(
...     '<mujoco><option timestep="1e-4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody>'
...     '<keyframe><key name="push" qvel="0 0 0 1 0 0"/></keyframe></mujoco>'
... )
>>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
>>> result = mjflex.study(
...     spec.compile(), methods=("twist",), integrators=("rk4", "euler"), steps=(2e-4, 1e-4), variants=[],
...     repeat=1, bisect=0, progress=False,
... )
"""


with_study_example = with_shared_docstring({"study_example": EXAMPLE})


def _bracket(lo, hi):
    """``lo`` and ``hi`` [s] as text, with the fewest significant digits (3 to 6) that tell them apart."""
    for digits in range(3, 7):
        a, b = f"{lo:.{digits}g}", f"{hi:.{digits}g}"
        if a != b:
            break
    return a, b


@with_study_example
@dataclass
class Row:
    """One candidate of a study: a model variant, an element method, an integrator and a time step.

    ``StudyResult.rows`` holds one per run; ``StudyResult.records()`` gives them as flat dicts.

    Attributes
    ----------
    variant : str
        ``"full"`` for the model as given, else the name of the :class:`mjflex.Variant`.
    method : str
        ``"twist"`` or ``"dualquat"``; the file's own methods for its own setting (``"twist/dualquat"`` if mixed);
        ``"-"`` for a variant without elements.
    integrator : str
        MuJoCo integrator: ``"rk4"``, ``"euler"``, ``"implicitfast"`` or ``"discrete"``.
    timestep : float
        Time step [s].
    status : str
        ``"ok"`` (ran the whole duration), ``"diverged"`` (see ``divergence``) or ``"skipped"`` (projected past
        the study's ``max_run_wall``; see ``note``).
    wall_per_sim_s, cpu_per_sim_s : float or None
        Wall and thread CPU seconds of ``mj_step`` per simulated second: median of ``repeats`` interleaved
        timings (a diverged or skipped row: over the steps it took, once).
    cost : float or None
        The one of the two that the study ranks by (its ``clock``).
    wall_range : tuple of float or None
        Smallest and largest wall time over the repeats [s per simulated s].
    repeats : int
        Timing rounds behind the medians.
    pose_error : float or None
        Headline error, relative: the larger of ``position_error`` and ``rotation_error``.
    position_error, rotation_error : float or None
        Largest distance (angle) of a tracked body or site from its reference pose over the largest displacement
        (rotation) of any tracked item in the reference, in the study's frame.
    energy_error : float or None
        Largest deviation of the total energy from the reference's, over the reference's largest energy swing.
    frequency_error : float or None
        Largest relative difference of the first elastic natural frequencies from the full model's.
    divergence : Divergence or None
        Where and how the run diverged (time, step, element, reason; ``.text()`` says it in one line).
    note : str
        Why a row is special (skipped, above its recommended step).
    source : str
        ``"grid"`` (a candidate step), ``"bisection"`` (added by the search of the stability limit) or
        ``"model"`` (the file's own setting).
    model_setting : bool
        The model file's own integrator, step and methods.
    pareto : bool
        No other row is both cheaper and more accurate.
    beyond_limit : bool
        Ran through, but above the step its :class:`Limit` recommends: stable only for this scene, never
        recommended.

    Examples
    --------
    {study_example}
    >>> row = result.rows[0]
    >>> row.label, row.status, f"{row.pose_error:.0e}"
    ('rk4, twist, h = 0.0002 s', 'ok', '2e-05')
    """

    variant: str  # "full" for the model as given, else the Variant's name
    method: str  # "twist", "dualquat", the file's methods ("twist/dualquat" if mixed), "-" without elements
    integrator: str
    timestep: float  # [s]
    status: str  # "ok", "diverged" or "skipped"
    wall_per_sim_s: float | None = None  # median over interleaved repeats (diverged, skipped: the steps taken, once)
    cpu_per_sim_s: float | None = None  # the same with this thread's CPU time (robust to machine load)
    cost: float | None = None  # the one of the two the study ranks by (its ``clock``)
    wall_range: tuple[float, float] | None = None  # min and max over the repeats
    repeats: int = 0
    pose_error: float | None = None  # headline error, relative (see _metrics.Errors)
    position_error: float | None = None
    rotation_error: float | None = None
    energy_error: float | None = None
    frequency_error: float | None = None  # first elastic frequencies vs the reference model's
    divergence: Divergence | None = None
    note: str = ""
    source: str = "grid"  # "grid", "bisection" (stability search) or "model" (the file's own setting)
    model_setting: bool = False  # the model file's own integrator, step and methods
    pareto: bool = False
    beyond_limit: bool = False  # ran through above the step its Limit recommends: never recommended

    @property
    def label(self) -> str:
        """``"[variant: ]integrator, method, h = … s"``: the candidate in one line."""
        return f"{who(self.variant, self.integrator, self.method)}, h = {self.timestep:.3g} s"

    def to_dict(self):
        """The row as a dict of plain values (its ``divergence`` a dict too), as written to the JSON report."""
        return asdict(self)  # the divergence, a dataclass too, becomes a dict


@with_study_example
@dataclass
class Limit:
    """Largest stable step of one (variant, method, integrator): measured on the scene, advised, recommended.

    ``largest_stable``/``smallest_unstable`` bracket the limit of the study's own scene (measured
    runs). A mode the scene leaves unexcited cannot diverge in those runs, so the study also finds
    the advised limit (:func:`mjflex.step_advice`'s: MuJoCo's step linearized at the initial pose, for
    any motion; its bisection's last stable step ``linear_step``) and the mode that diverges above it
    (:mod:`mjflex.app.study._stability`), and recommends the smaller of the two, checked by a run of
    the scene with a random velocity perturbation (``checks``).

    Attributes
    ----------
    variant, method, integrator : str
        The group, as in :class:`Row`.
    largest_stable : float or None
        Largest step that ran the whole duration [s] (None: every step diverged).
    smallest_unstable : float or None
        Smallest larger step that diverged [s] (None: every step tried ran through).
    divergence : Divergence or None
        How the run at ``smallest_unstable`` diverged.
    steps_given : bool
        The candidate steps were given (``steps=``), not the default range.
    linear_step : float or None
        The last stable step of the bisection of the advised limit [s]: the one-step map of MuJoCo's step
        linearized at the initial pose at rest (:func:`mjflex.step_advice`: the limit for any motion, with the
        model's damping) is stable there. The advised limit itself lies between it and ``linear_unstable``.
    linear_unstable : float or None
        The bisection's first unstable step above ``linear_step`` [s] (within the study's ``limit_rtol`` of it;
        None where there is no ``linear_step``, and in reports recorded before it was).
    linear_note : str
        Why there is no ``linear_step``, when there is none.
    linear_mode : dict or None
        The mode that diverges first above ``linear_step``: ``frequency_hz``, ``oscillating``, ``where`` (the
        element direction or joint storing most of its strain energy), ``share`` and ``scene_share`` (the part
        of the scene's initial energy in it).
    checks : list of dict
        The perturbed runs: ``timestep``, ``status`` (``"ok"`` or ``"diverged"``), ``time`` and ``divergence``.
    recommended : float or None
        The smaller of the two limits, halved until a perturbed run went through [s].
    checked : bool
        The advised limit and the perturbed runs were done.

    Examples
    --------
    {study_example}
    >>> limit = result.limits[0]
    >>> limit.integrator, limit.largest_stable, limit.smallest_unstable, limit.recommended
    ('rk4', 0.0002, None, 0.0002)
    >>> limit.linear_note  # no advised limit below the search's end: this block's spring is soft
    'the linearized model is stable at every step up to 0.00291 s'
    """

    variant: str
    method: str
    integrator: str
    largest_stable: float | None  # largest step that ran the whole duration [s]
    smallest_unstable: float | None  # smallest larger step that diverged [s]
    divergence: Divergence | None = None  # how the smallest unstable step diverged
    steps_given: bool = False  # the candidate steps were given (steps=), not the default range
    linear_step: float | None = None  # the bisection's last step at which the linearized model is stable [s]
    linear_note: str = ""  # why there is no linear_step, when there is none
    linear_mode: dict | None = None  # the mode diverging first above it: frequency_hz, where, share, scene_share
    checks: list = field(default_factory=list)  # perturbed runs: {"timestep", "diverged": text or None}
    recommended: float | None = None  # the smaller of the two limits, halved until a perturbed run went through
    checked: bool = False  # the advised limit and the perturbed runs were done
    linear_unstable: float | None = None  # the bisection's first unstable step above linear_step [s]

    def measured_text(self) -> str:
        """The bracket measured on the scene, in words (or what to widen when there is none)."""
        if self.largest_stable is None:
            return f"diverged at every step tried (smallest {self.smallest_unstable:.3g} s)"
        if self.smallest_unstable is None:
            widen = "add a larger step to --steps (steps=)" if self.steps_given else "widen with --max-step (max_step=)"
            return f"stable at every step tried (largest {self.largest_stable:.3g} s); {widen}"
        lo, hi = _bracket(self.largest_stable, self.smallest_unstable)
        return f"stable at {lo} s, diverges at {hi} s"

    def mode_text(self) -> str:
        """The mode that diverges first above the advised limit, in words (empty without one)."""
        mode = self.linear_mode
        if not mode:
            return ""
        hz = mode["frequency_hz"]
        if mode["oscillating"]:
            what = f"the {hz:.0f} Hz mode" if hz >= 1000 else f"the {hz:.4g} Hz mode"
        else:
            what = f"a damping-limited motion ({2 * math.pi * hz:.3g} 1/s)"
        where = (f"strain energy mostly in {mode['where']}" if mode["kind"] == "strain"
                 else f"moving mostly {mode['where']}")  # fmt: skip
        return f"{what} ({where}, {100 * mode['share']:.3g} %; {mode['scene_share']:.1g} of the scene's initial energy)"

    def linear_text(self) -> str:
        """The bisection's bracket of the advised limit, in words (or why there is none)."""
        if self.linear_step is None:
            return self.linear_note
        if self.linear_unstable is None:  # a report recorded before the bracket's upper end was
            return (f"advised limit at or above {self.linear_step:.3g} s (the last stable step of its bisection; "
                    "the unstable end was not recorded)")  # fmt: skip
        lo, hi = _bracket(self.linear_step, self.linear_unstable)
        return f"advised limit between {lo} s (stable) and {hi} s (unstable)"

    def text(self) -> str:
        """The limit in one line: measured bracket, advised bracket and its mode, the step to use (the report's)."""
        head = f"{who(self.variant, self.integrator, self.method)}: {self.measured_text()}"
        if not self.checked:
            return head
        head += f"; {self.linear_text()}"
        if self.linear_step is not None:
            head += f", set by {self.mode_text()}"
        over = [c for c in self.checks if c["status"] == "diverged" and self.recommended is not None
                and c["timestep"] > self.recommended * (1 + 1e-9)]  # fmt: skip
        if over and self.linear_step is not None:
            head += (f". The scene leaves that mode unexcited: with a random velocity perturbation of relative size "
                     f"{PERTURBATION:g} the run at {over[-1]['timestep']:.3g} s diverged at t = "
                     f"{over[-1]['time']:.3g} s")  # fmt: skip
        if self.recommended is not None:
            return head + f". Use h <= {self.recommended:.3g} s (a perturbed run there goes through)"
        if self.checks:
            return head + f". No step recommended: perturbed runs diverged down to {self.checks[-1]['timestep']:.3g} s"
        return head

    def to_dict(self):
        """The limit as a dict of plain values, as written to the JSON report."""
        return asdict(self)


@with_study_example
@dataclass
class Reference:
    """The study's reference run: RK4 refined until two successive halvings of the step agree.

    Attributes
    ----------
    integrator, method : str
        ``"rk4"`` and the element method of the reference (the model's own).
    timestep : float or None
        The step of the reference run [s] (None: every refinement diverged).
    agreement : float or None
        Pose error between the last two refinements (relative).
    error_estimate : float or None
        Of the reference itself: ``agreement / 15`` (RK4 is 4th order).
    converged : bool
        ``agreement`` reached the study's ``reference_tol``.
    attempts : list of dict
        Every refinement: ``timestep``, ``status``, ``agreement_with_previous``.
    wall_per_sim_s, cpu_per_sim_s, cost : float or None
        Its cost, as in :class:`Row`.
    wall_range : tuple of float or None
        Smallest and largest wall time over the repeats.
    repeats : int
        Timing rounds.
    observed_order : float or None
        ``log2`` of the ratio of successive agreements (4 for RK4 in its asymptotic range).

    Examples
    --------
    {study_example}
    >>> ref = result.reference
    >>> ref.converged, ref.timestep, round(ref.observed_order)
    (True, 2.5e-05, 4)
    """

    integrator: str
    method: str
    timestep: float | None  # the step of the reference run [s]
    agreement: float | None  # pose error between the last two refinements (relative)
    error_estimate: float | None  # of the reference itself: agreement / 15 (RK4 is 4th order)
    converged: bool
    attempts: list = field(default_factory=list)  # [{timestep, status, agreement_with_previous}]
    wall_per_sim_s: float | None = None
    cpu_per_sim_s: float | None = None
    cost: float | None = None
    wall_range: tuple[float, float] | None = None
    repeats: int = 0
    observed_order: float | None = None  # log2 of the ratio of successive agreements

    def text(self) -> str:
        """The reference in one line: its step, whether it converged, the agreement and estimated error."""
        if self.timestep is None:
            return "no reference: every refinement diverged"
        head = f"reference: {self.integrator.upper()} ({self.method}) at h = {self.timestep:.3g} s"
        if self.agreement is None:
            return f"{head}, NOT verified: no second refinement ran through to compare it with"
        state = "converged" if self.converged else "NOT converged to the requested tolerance"
        order = f", observed order {self.observed_order:.1f}" if self.observed_order else ""
        return (
            f"{head}, {state}: the last two refinements agree to {self.agreement:.2g} (pose), estimated error "
            f"{self.error_estimate:.2g}{order}"
        )
