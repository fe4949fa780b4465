"""The study's options, every one checked before the study loads, runs or writes anything.

:func:`check_options` raises :class:`StudyError` (a ValueError) for a value out of range and
TypeError for a value of the wrong type, naming the option as the caller spells it: the
keyword of :func:`mjflex.app.study.study`, or the command line's ``--option`` (``spell``).
"""

import math
import os

from ...core import validation
from ..output import folder_problem
from ..simulate import INTEGRATORS
from ._scene import StudyError

METHODS = ("twist", "dualquat")
CLOCKS = ("cpu", "wall")


def _sequence(value, name, what, valid=True):
    """TypeError naming ``name`` unless ``value`` is a non-empty list or tuple of ``what`` (``valid``: items are)."""
    if not valid or isinstance(value, str) or not isinstance(value, list | tuple) or not value:
        raise TypeError(f"{name} must be a non-empty list of {what}; got {validation.shorten(value)}")


def _names(value, name, allowed):
    _sequence(value, name, f"names from {list(allowed)}")
    bad = [v for v in value if v not in allowed]
    if bad:
        raise StudyError(f"unknown choice(s) {validation.shorten(bad)} for {name}: choose from {list(allowed)}")


def _numbers(values, name, what, suffix, **bounds):
    """StudyError naming ``name[i]`` for the first of ``values`` (a list of ``what``) out of ``bounds``."""
    _sequence(values, name, what)
    for i, v in enumerate(values):
        try:
            validation.check_number(v, f"{name}[{i}]", **bounds)
        except ValueError as exc:
            raise StudyError(f"{exc}{suffix}") from None


def check_options(opts: dict, out=None, spell=lambda name: name) -> None:
    """Check the keyword arguments ``opts`` of :func:`mjflex.app.study.study` (and ``out``)."""

    def number(key, **bounds):
        value = opts[key]
        if value is None:
            return None
        try:
            return validation.check_number(value, spell(key), **bounds)
        except ValueError as exc:
            raise StudyError(str(exc)) from None

    for key in ("duration", "max_step", "min_step", "reference_step", "limit_rtol"):
        number(key, above=0.0)
    for key, low in (("step_count", 1), ("repeat", 1), ("samples", 1), ("frequencies", 1), ("bisect", 0),
                     ("max_refinements", 0)):  # fmt: skip
        if opts[key] is None:
            raise TypeError(f"{spell(key)} must be an integer >= {low}; got None")
        number(key, integer=True, at_least=low)
    number("reference_tol", above=0.0, below=1.0)
    wall = opts["max_run_wall"]
    if not (isinstance(wall, float) and wall == math.inf):  # inf: no budget
        number("max_run_wall", above=0.0)
    if opts["min_step"] is not None and opts["max_step"] is not None and opts["min_step"] > opts["max_step"]:
        raise StudyError(
            f"{spell('min_step')} {opts['min_step']:g} s is above {spell('max_step')} {opts['max_step']:g} s; swap them"
        )
    if opts["steps"] is not None:
        _numbers(opts["steps"], spell("steps"), "time steps [s]", " (time steps are positive numbers of seconds)",
                 above=0.0)  # fmt: skip
        given = [spell(k) for k in ("max_step", "min_step") if opts[k] is not None]
        if given:
            raise StudyError(
                f"{spell('steps')} lists the candidate steps, so {' and '.join(given)} (which set the default "
                f"range) would be ignored; give one or the other"
            )
    _numbers(opts["targets"], spell("targets"), "relative errors", ": targets are relative pose errors, 0.01 = 1 %",
             above=0.0, at_most=1.0)  # fmt: skip
    _names(opts["methods"], spell("methods"), METHODS)
    _names(opts["integrators"], spell("integrators"), sorted(INTEGRATORS))
    if opts["clock"] not in CLOCKS:
        raise StudyError(f"{spell('clock')} must be 'cpu' or 'wall'; got {validation.shorten(opts['clock'])}")
    track = opts["track"]
    if track is not None:
        names = not isinstance(track, list | tuple) or all(isinstance(t, str) and t for t in track)
        _sequence(track, spell("track"), "body or site names", names)
    if not isinstance(opts["frame"], str):
        raise TypeError(
            f"{spell('frame')} must be a body name, 'world' or 'auto'; got {validation.shorten(opts['frame'])}"
        )
    keyframe = opts["keyframe"]
    if keyframe is not None and (isinstance(keyframe, bool) or not isinstance(keyframe, str | int)):
        raise TypeError(f"{spell('keyframe')} must be a keyframe name or index; got {validation.shorten(keyframe)}")
    if out is not None:
        problem = folder_problem(os.fspath(out), spell("out"))
        if problem:
            raise StudyError(problem)


def who(variant, integrator, method):
    """``"[variant: ]integrator[, method]"``: the label of a candidate without its step."""
    return f"{'' if variant == 'full' else variant + ': '}{integrator}{'' if method == '-' else ', ' + method}"
