"""The study's results: one row per candidate, stability limits, the reference, and their reports.

The table is a list of dataclass rows rather than a pandas or xarray object: the rows are
heterogeneous records (a variant, an integrator, a step, a status, optional errors, a divergence)
rather than a dense labelled grid, and the core package should not need pandas. ``records()``
gives flat dicts, so ``pandas.DataFrame(result.records())`` is one line for those who want it.
"""

import json
import math
import os
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from ..output import replace_together
from ._options import who
from ._rows import Limit, Reference, Row, with_study_example
from ._run import Divergence
from ._stability import PERTURBATION


def _fmt(x, spec=".2g", none="-"):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return none
    return format(x, spec)


def _percent(x, floor=0.0):
    if x is None:
        return "-"
    if x < floor:
        return f"< {floor * 100:.1g} %"
    return f"{x * 100:.2g} %"


#: The JSON report's keys, in order (:meth:`StudyResult.to_dict`), and the attributes of those named otherwise.
_REPORT_KEYS = ("model", "initial_state", "duration", "sample_interval", "frame", "tracked", "model_setting",
                "reference", "error_floor", "rows", "limits", "frequencies_hz", "highest_frequency_hz",
                "fastest_rate_per_s", "clock", "variants", "targets", "recommendation", "needs", "notes", "message",
                "command", "date", "wall_s")  # fmt: skip
_ATTRIBUTES = {"frequencies_hz": "frequencies", "highest_frequency_hz": "highest_frequency",
               "fastest_rate_per_s": "fastest_rate"}  # fmt: skip


@with_study_example
@dataclass
class StudyResult:
    """Everything a study measured, what it recommends, and its reports: what :func:`mjflex.study` returns.

    Attributes
    ----------
    model : str
        The model's name or path, as given.
    initial_state : str
        Where the runs start (a keyframe, or ``qpos``/``qvel`` given).
    duration, sample_interval : float
        Simulated time of each run and the interval at which poses are compared [s].
    frame : str
        Body the poses are taken in (``"world"`` for the world frame).
    tracked : list of str
        Bodies or sites whose poses are compared.
    model_setting : dict
        The model file's own ``integrator``, ``timestep`` and ``method``.
    reference : Reference or None
        The reference run (None: the study stopped before it had one).
    rows : list of Row
        One per candidate run, in the order they ran.
    limits : list of Limit
        One per (variant, method, integrator): the measured and advised stability limits and the step to use.
    frequencies : dict
        ``"variant/method"`` -> the first elastic natural frequencies of the linearized model [Hz].
    highest_frequency : float or None
        Highest natural frequency of the model as given [Hz].
    fastest_rate : float or None
        Largest ``|eigenvalue|`` of the linearized model with its damping [1/s].
    variants : dict
        Variant name -> its report (what it keeps, merges and drops).
    targets : tuple of float
        Pose-error targets of :meth:`recommendation` (relative).
    clock : str
        What ``cost`` is: ``"cpu"`` (thread CPU time) or ``"wall"``.
    notes : list of str
        Remarks of the study (a variant that changed nothing, a reduced range).
    message : str or None
        Why the study stopped early, if it did.
    date : str
        UTC start time, ISO 8601.
    wall_s : float or None
        Wall time of the whole study [s].
    command : str
        The command line that ran it (set by ``python -m mjflex study``).

    See Also
    --------
    mjflex.study : runs a study and returns this.

    Examples
    --------
    {study_example}
    >>> [(row.integrator, row.timestep, row.status) for row in result.rows]
    [('rk4', 0.0002, 'ok'), ('rk4', 0.0001, 'ok'), ('euler', 0.0002, 'ok'), ('euler', 0.0001, 'ok')]
    >>> [(limit.integrator, limit.recommended) for limit in result.limits]  # the step to use, per integrator
    [('rk4', 0.0002), ('euler', 0.0002)]
    >>> len(result.records()), sorted(result.records()[0])[:4]  # pandas.DataFrame(result.records()) for a table
    (4, ['beyond_limit', 'cost', 'cpu_per_sim_s', 'divergence'])

    :meth:`recommendation` and :meth:`needs` name the cheapest candidate per error target (costs are measured, so
    they vary from run to run).

    ``result.write("out")`` writes ``study_<model>.md``, ``.json`` and the Pareto plot ``.png``.
    """

    model: str
    initial_state: str = ""
    duration: float = 0.0  # [s]
    sample_interval: float = 0.0  # [s]
    frame: str = ""
    tracked: list = field(default_factory=list)
    model_setting: dict = field(default_factory=dict)  # {"integrator", "timestep", "method"} of the model file
    reference: Reference | None = None
    rows: list = field(default_factory=list)
    limits: list = field(default_factory=list)
    frequencies: dict = field(default_factory=dict)  # "variant/method" -> first elastic frequencies [Hz]
    highest_frequency: float | None = None  # [Hz], of the model as given
    fastest_rate: float | None = None  # largest |eigenvalue| of the linearized model with damping [1/s]
    variants: dict = field(default_factory=dict)  # name -> report of the variant
    targets: tuple = (0.1, 0.01, 1e-4)
    clock: str = "cpu"  # what the cost is measured with: "cpu" (thread CPU time) or "wall"
    notes: list = field(default_factory=list)
    message: str | None = None  # why the study stopped early, if it did
    date: str = ""  # UTC start time, ISO 8601
    wall_s: float | None = None  # wall time of the whole study [s]
    command: str = ""  # the command line that ran it (set by ``python -m mjflex study``)

    # ------------------------------------------------------------------ selections

    @property
    def floor(self) -> float:
        """Errors below this are within the reference's own error and not resolved."""
        r = self.reference
        return 0.0 if r is None or r.error_estimate is None else 3.0 * r.error_estimate

    def ok_rows(self):
        """Rows that ran through with an error and a cost, at a step their limit recommends."""
        return [r for r in self.rows if r.status == "ok" and r.pose_error is not None and r.cost and not r.beyond_limit]

    def flag_beyond_limits(self):
        """Flag (and annotate) the rows that ran through at a step above their group's recommended step."""
        limits = {(lim.variant, lim.method, lim.integrator): lim for lim in self.limits}
        for row in self.rows:
            lim = limits.get((row.variant, row.method, row.integrator))
            if row.status != "ok" or lim is None or not lim.checked:
                continue
            if lim.recommended is None or row.timestep > lim.recommended * (1.0 + 1e-9):
                row.beyond_limit = True
                why = f"above the recommended {lim.recommended:.3g} s" if lim.recommended else "no step recommended"
                row.note = (f"{why}: stable only for this scene (see its stability limit); not recommended. "
                            + row.note).strip()  # fmt: skip

    def mark_pareto(self):
        """Flag the rows no other row beats in both cost and pose error."""
        best = np.inf
        for row in self.rows:
            row.pareto = False
        for row in sorted(self.ok_rows(), key=lambda r: (r.cost, r.pose_error)):
            if row.pose_error < best:
                row.pareto, best = True, row.pose_error

    def cheapest(self, target, key="pose_error"):
        """The cheapest ok row with ``key`` error at most ``target`` (None if none)."""
        rows = [r for r in self.ok_rows() if getattr(r, key) is not None and getattr(r, key) <= target]
        return min(rows, key=lambda r: r.cost) if rows else None

    def model_setting_row(self):
        """The row of the model file's own integrator, step and methods (None if it did not run)."""
        return next((r for r in self.rows if r.model_setting), None)

    def _speedups(self, row):
        parts = []
        if self.reference is not None and self.reference.cost:
            parts.append(f"{self.reference.cost / row.cost:.3g}x faster than the reference")
        own = self.model_setting_row()
        if own is not None and own.status == "ok" and own is not row:
            parts.append(f"{own.cost / row.cost:.3g}x the speed of the model's own setting")
        return ", ".join(parts)

    def recommendation(self) -> list[str]:
        """One line per error target: the cheapest candidate that meets it."""
        lines = []
        for target in self.targets:
            row = self.cheapest(target)
            if row is None:
                lines.append(f"for <= {target * 100:g} % error: no candidate reached it")
                continue
            lines.append(
                f"for <= {target * 100:g} % error: {row.label} ({row.cost:.3g} s per simulated s, "
                f"error {_percent(row.pose_error, self.floor)}), {self._speedups(row)}"
            )
        if self.rows and not any(r.status == "ok" for r in self.rows if r.source != "model"):
            lines.append("every candidate step diverged or was skipped: see the stability limits and divergences")
        return lines

    NEEDS_COLUMNS = ("need", "choice", "s per simulated s", "pose error", "energy error", "vs the model's setting")

    def _need(self, need, row):
        if row is None:
            return (need, "none of the candidates", "-", "-", "-", "-")
        own = self.model_setting_row()
        speed = "-"
        if own is not None and own.status == "ok" and row.cost:
            speed = "the setting itself" if row is own else f"{own.cost / row.cost:.3g}x faster"
        cost = _fmt(row.cost, ".3g") if row.status == "ok" else row.status
        return (need, row.label, cost, _percent(row.pose_error, self.floor), _percent(row.energy_error), speed)

    def needs(self) -> list[tuple]:
        """Rows of the "which choice for which need" table (columns: ``NEEDS_COLUMNS``)."""
        names = ("a quick look", "engineering answers", "validation") + ("",) * len(self.targets)
        out = [self._need(f"{need or 'error'} (pose error <= {t * 100:g} %)", self.cheapest(t))
               for t, need in zip(self.targets, names, strict=False)]  # fmt: skip
        out.append(self._need("energy within 1 %", self.cheapest(0.01, key="energy_error")))
        for name in self.variants:
            rows = [r for r in self.ok_rows() if r.variant == name and r.pose_error <= 0.01]
            best = min(rows, key=lambda r: r.cost) if rows else None
            out.append(self._need(f"model variant '{name}' (<= 1 %)", best))
        stable = [lim for lim in self.limits if lim.largest_stable]
        if stable:
            checked = [lim for lim in stable if lim.checked]
            if checked:
                usable = [lim for lim in checked if lim.recommended]
                lim = max(usable, key=lambda x: x.recommended) if usable else None
                text = f"{who(lim.variant, lim.integrator, lim.method)}: h <= {lim.recommended:.3g} s" if lim else "-"
            else:
                lim = max(stable, key=lambda x: x.largest_stable)
                text = lim.text()
            out.append(("the largest stable step", text, "-", "-", "-", "-"))
        own = self.model_setting_row()
        if own is not None:
            out.append(self._need("what the model file uses now", own))
        return out

    # ------------------------------------------------------------------ output

    def records(self) -> list[dict]:
        """Flat dicts, one per row (``pandas.DataFrame(result.records())`` works)."""
        out = []
        for r in self.rows:
            d = r.to_dict()
            div = d.pop("divergence")
            d["divergence"] = None if div is None else Divergence(**div).text()
            out.append(d)
        return out

    def to_dict(self):
        """Everything as a dict of plain values: the JSON report (``write``), with the recommendation and needs."""
        computed = {
            "reference": None if self.reference is None else asdict(self.reference), "error_floor": self.floor,
            "rows": [r.to_dict() for r in self.rows], "limits": [lim.to_dict() for lim in self.limits],
            "targets": list(self.targets), "recommendation": self.recommendation(),
            "needs": [dict(zip(self.NEEDS_COLUMNS, row, strict=True)) for row in self.needs()],
        }  # fmt: skip
        return {k: computed[k] if k in computed else getattr(self, _ATTRIBUTES.get(k, k)) for k in _REPORT_KEYS}

    @classmethod
    def from_dict(cls, report) -> "StudyResult":
        """The result that a JSON report holds (the dict of :meth:`to_dict`), to write its reports again.

        Nothing is run: :meth:`to_markdown`, :meth:`recommendation` and :meth:`needs` are computed again from the
        recorded rows and limits, so a report's Markdown can be made again after its wording changed. A report
        recorded before a field existed gets that field's default (``targets``: the default targets).

        Parameters
        ----------
        report : dict
            A study's JSON report, as :meth:`write` wrote it and ``json.load`` read it.

        Returns
        -------
        StudyResult
        """

        def divergence(x):
            return None if x is None else Divergence(**x)

        def ranged(x):
            return {**x, "wall_range": None if x.get("wall_range") is None else tuple(x["wall_range"])}

        names = {f.name for f in fields(cls)}
        given = {_ATTRIBUTES.get(k, k): v for k, v in report.items() if _ATTRIBUTES.get(k, k) in names}
        ref = report["reference"]
        return cls(**{
            **given, "reference": None if ref is None else Reference(**ranged(ref)),
            "targets": tuple(given.get("targets", cls.targets)),
            "rows": [Row(**{**ranged(r), "divergence": divergence(r["divergence"])}) for r in report["rows"]],
            "limits": [Limit(**{**x, "divergence": divergence(x["divergence"])}) for x in report["limits"]],
        })  # fmt: skip

    def summary_lines(self) -> list[str]:
        """The report's summary, one line each: model, run, reference, frequencies, wall time, notes."""
        lines = [f"model {self.model}" + (f", initial state: {self.initial_state}" if self.initial_state else "")]
        if self.duration:
            clock = "CPU" if self.clock == "cpu" else "wall"
            lines.append(
                f"{self.duration * 1e3:.4g} ms simulated, sampled every {self.sample_interval * 1e3:.3g} ms; poses of "
                f"{len(self.tracked)} tracked item(s) relative to {self.frame}; cost in {clock} seconds of mj_step "
                "per simulated second"
            )
        if self.reference is not None:
            lines.append(self.reference.text())
        if self.highest_frequency:
            first = self.frequencies.get("full", [])[:3]
            lines.append(
                f"first elastic frequencies {', '.join(f'{f:.4g}' for f in first)} Hz; highest "
                f"{self.highest_frequency:.4g} Hz; fastest rate with damping {self.fastest_rate:.4g} 1/s"
            )
        if self.wall_s is not None:
            lines.append(f"study wall time {self.wall_s:.0f} s" + (f" (`{self.command}`)" if self.command else ""))
        return lines + [f"note: {n}" for n in self.notes] + ([f"STOPPED: {self.message}"] if self.message else [])

    def to_markdown(self) -> str:
        """The Markdown report: summary, recommendation, needs, stability limits, variants and every candidate."""
        floor = self.floor
        out = [f"# Speed-accuracy study: {self.model}", ""]
        out += [f"- {line}" for line in self.summary_lines()]
        out += ["", "## Recommendation", ""] + [f"- {line}" for line in self.recommendation()]
        out += ["", "## Which choice for which need", "", "| " + " | ".join(self.NEEDS_COLUMNS) + " |",
                "|---" * len(self.NEEDS_COLUMNS) + "|"]  # fmt: skip
        out += ["| " + " | ".join(row) + " |" for row in self.needs()]
        if self.limits:
            out += ["", "## Largest stable step", ""]
            if any(lim.checked for lim in self.limits):
                out += [
                    "Measured: the bisection of this scene's runs, its last stable and first diverged step. Advised "
                    "limit: mjflex.step_advice's, MuJoCo's step linearized at the initial pose, for any motion, "
                    "bracketed by a bisection between its last stable and first unstable step; the mode named is the "
                    "one that diverges first above it. Used: the smaller of the two stable steps, checked by a run of "
                    f"the scene with a random velocity perturbation of relative size {PERTURBATION:g}; candidates "
                    "above it ran through only because the scene leaves a mode unexcited and are never recommended.",
                    "",
                ]
            out += [f"- {lim.text()}" for lim in self.limits]
        own = self.model_setting
        at_file = [r for r in self.rows if own and r.integrator == own.get("integrator")
                   and abs(r.timestep - own.get("timestep", -1.0)) <= 1e-9 * r.timestep]  # fmt: skip
        if at_file:
            out += ["", "## At the model file's step", "",
                    f"Every model at the file's own step ({own['timestep']:.3g} s) and integrator "
                    f"({own['integrator']}): cost per simulated second and error against the reference, side by side.",
                    "",
                    "| variant | method | status | cost per sim s | pose error |", "|---|---|---|---|---|"]  # fmt: skip
            out += [f"| {r.variant} | {r.method} | {r.status} | {_fmt(r.cost, '.3g')} | "
                    f"{_percent(r.pose_error, floor)} |" for r in at_file]  # fmt: skip
        if self.variants:
            out += ["", "## Variants", ""] + [f"- **{k}**: {v}" for k, v in self.variants.items()]
        clock = "CPU" if self.clock == "cpu" else "wall"
        out += [
            "", "## Candidates", "",
            f"Errors are relative to the reference's motion (pose) and energy swing; below {_percent(floor * 1.0001)} "
            f"they are within the reference's own error. Cost: {clock} seconds of `mj_step` per simulated second, "
            "median of interleaved repeats (CPU time of the stepping thread is what an idle core's wall time would be; "
            "the wall time of a shared machine is inflated by its other work). In parentheses: over the steps a "
            "diverged run took, once. P: on the Pareto front.", "",
            f"| variant | method | integrator | h [s] | status | {clock} s / sim s | wall s / sim s | pose error | "
            "energy error | frequency error | P | note |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|",
        ]  # fmt: skip
        for r in self.rows:
            note = r.divergence.text() if r.divergence else r.note
            if r.model_setting:
                note = ("model's own setting. " + note).strip()
            cost, wall = _fmt(r.cost, ".3g"), _fmt(r.wall_per_sim_s, ".3g")
            if r.status != "ok":
                cost, wall = f"({cost})", f"({wall})"
            out.append(
                f"| {r.variant} | {r.method} | {r.integrator} | {r.timestep:.3g} | {r.status} | {cost} | {wall} | "
                f"{_percent(r.pose_error, floor)} | {_percent(r.energy_error)} | {_percent(r.frequency_error)} | "
                f"{'*' if r.pareto else ''} | {note} |"
            )
        return "\n".join(out) + "\n"

    def write(self, out_dir, *, stem=None, plot=True, partial=False) -> list[str]:
        """Write ``<stem>.md``, ``<stem>.json`` and (with candidates) ``<stem>.png``; returns the paths.

        The set is replaced together (:func:`mjflex.app.output.replace_together`): written beside,
        renamed into place once all were written, and a ``.png`` of an earlier study that this one
        lacks is removed, so the three files always come from one study. A complete study also
        removes the ``<stem>.partial.*`` files of an earlier one that stopped. ``partial``: a study
        that stopped early writes ``<stem>.partial.md``/``.json``/``.png`` instead, beside the
        earlier complete results, which it leaves as they were.
        """
        os.makedirs(out_dir, exist_ok=True)
        stem = stem or f"study_{os.path.splitext(os.path.basename(self.model))[0]}"
        full = os.path.join(out_dir, stem)
        base = full + ".partial" if partial else full

        def markdown(path):
            with open(path, "w") as f:
                f.write(self.to_markdown())

        def data(path):
            with open(path, "w") as f:
                json.dump(self.to_dict(), f, indent=1, default=float)

        writers = {base + ".md": markdown, base + ".json": data}
        if plot and self.rows:
            from ._plot import pareto_plot  # matplotlib loads only when a plot is written

            writers[base + ".png"] = lambda path: pareto_plot(self, path)
        stale = [base + ".png"] + ([] if partial else [full + ".partial" + ext for ext in (".md", ".json", ".png")])
        return replace_together(writers, stale)
