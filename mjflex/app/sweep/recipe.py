"""What a sweep varies: a model source plus a module-level ``edit(spec, **params)``.

A :class:`Recipe` is small and picklable, so it is what travels to worker processes (a
process pool, a Dask cluster); each worker builds its models from it. Models themselves are
never shipped.
"""

import inspect
import os
import pickle
from collections.abc import Callable
from dataclasses import dataclass

import mujoco


def _is_xml_text(source: str) -> bool:
    return source.lstrip().startswith("<")


@dataclass(frozen=True)
class Recipe:
    """A family of models: a source model and how one set of parameters edits it.

    Parameters
    ----------
    source : str or os.PathLike
        An MJCF file (read on the worker: with a cluster it must be on a shared file system)
        or the MJCF text itself (a string that starts with ``<``; travels with the recipe,
        but file assets with relative paths are then resolved from the worker's directory).
    edit : callable, optional
        ``edit(spec, **params)``: changes the ``mujoco.MjSpec`` of the source for one variant
        in place (or returns a new ``MjSpec``). It must be defined at the top level of an
        importable module so that worker processes can import it (lambdas and closures
        cannot travel to a process pool; Dask's cloudpickle accepts them). Without ``edit``
        the grid must be empty.
    keyframe : str or int, optional
        Initial state of every variant: a keyframe name or index. Default: the model's
        reference state ``qpos0`` at rest (``mj_resetData``).

    Notes
    -----
    The build is ``MjSpec.from_file`` / ``from_string`` -> ``edit`` -> ``compile``, on the
    worker, for every variant; it must be deterministic (same parameters, same model), which
    is what makes a sweep reproducible across executors.

    Examples
    --------
    A block on a leaf spring, as MJCF text, and an ``edit`` that scales the spring's stiffness:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option timestep="1e-4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody>'
    ...     '<keyframe><key name="push" qvel="0 0 0 1 0 0"/></keyframe></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> from mjflex.app.sweep import edit_flexure, flexure_matrices
    >>> def stiffer(spec, scale):  # at the top level of a module when variants run in other processes
    ...     K, _ = flexure_matrices(spec, "leaf")
    ...     edit_flexure(spec, "leaf", K=scale * K)
    >>> recipe = mjflex.Recipe(spec.to_xml(), stiffer, keyframe="push")
    >>> model = recipe.build(scale=4.0)  # one variant, as a sweep builds it on its worker
    >>> print(mjflex.Flexures(model).records[0].K[3, 3])
    40000.0

    :func:`mjflex.sweep` runs a recipe over a grid of parameters.
    """

    source: str
    edit: Callable | None = None
    keyframe: str | int | None = None

    def __post_init__(self):
        source = os.fspath(self.source) if isinstance(self.source, os.PathLike) else self.source
        if not isinstance(source, str) or not source.strip():
            raise TypeError(f"Recipe source must be an MJCF file path or MJCF text; got {self.source!r}")
        if not _is_xml_text(source) and not os.path.isfile(source):
            raise FileNotFoundError(f"Recipe source {source!r}: no such MJCF file (MJCF text must start with '<')")
        object.__setattr__(self, "source", source)
        if self.edit is not None and not callable(self.edit):
            raise TypeError(f"Recipe edit must be a function edit(spec, **params); got {self.edit!r}")
        if self.keyframe is not None and not isinstance(self.keyframe, str | int):
            raise TypeError(f"Recipe keyframe must be a keyframe name or index; got {self.keyframe!r}")

    @property
    def is_file(self) -> bool:
        """True when ``source`` is a path to an MJCF file, False when it is MJCF text."""
        return not _is_xml_text(self.source)

    def describe(self) -> str:
        """One line for the result's attributes: source, edit function and keyframe."""
        if self.is_file:
            rel = os.path.relpath(self.source)
            src = self.source if rel.startswith("..") else rel  # no machine-specific prefix in records
        else:
            src = f"MJCF text ({len(self.source)} characters)"
        edit = "none" if self.edit is None else f"{self.edit.__module__}.{getattr(self.edit, '__qualname__', '?')}"
        return f"source: {src}; edit: {edit}; keyframe: {self.keyframe!r}"

    def check_parameters(self, names) -> None:
        """Raise ``TypeError`` naming the parameters ``edit`` does not accept (or lacks)."""
        names = list(names)
        if self.edit is None:
            if names:
                raise TypeError(f"the grid varies {names} but the recipe has no edit(spec, **params) to apply them")
            return
        try:
            inspect.signature(self.edit).bind(None, **dict.fromkeys(names))
        except TypeError as exc:
            raise TypeError(
                f"edit {self.edit.__qualname__}{inspect.signature(self.edit)} cannot take the grid's parameters "
                f"{names}: {exc}. Give edit(spec, **params) one keyword argument per grid parameter."
            ) from None
        except ValueError:  # no signature (a builtin): accept
            pass

    def check_picklable(self, observe, *, cloud=False) -> None:
        """Raise ``TypeError`` if the recipe or ``observe`` cannot be sent to worker processes."""
        dumps = pickle.dumps
        if cloud:
            import cloudpickle  # late: the dask extra's, only for recipes defined in __main__

            dumps = cloudpickle.dumps
        for what, obj in (("recipe edit", self.edit), ("observe", observe)):
            try:
                dumps(obj)
            except Exception as exc:
                name = getattr(obj, "__qualname__", repr(obj))
                raise TypeError(
                    f"{what} {name} cannot be sent to worker processes ({type(exc).__name__}: {exc}). Define it "
                    "at the top level of an importable module (not a lambda, closure or a function of __main__ "
                    "run as a script)."
                ) from None

    def spec(self, **params) -> mujoco.MjSpec:
        """The edited ``MjSpec`` of one variant."""
        spec = mujoco.MjSpec.from_file(self.source) if self.is_file else mujoco.MjSpec.from_string(self.source)
        if self.edit is not None:
            edited = self.edit(spec, **params)
            if edited is not None:
                if not isinstance(edited, mujoco.MjSpec):
                    raise TypeError(
                        f"edit {self.edit.__qualname__} returned {type(edited).__name__}; return None (edit the "
                        "spec in place) or a mujoco.MjSpec"
                    )
                spec = edited
        return spec

    def build(self, **params) -> mujoco.MjModel:
        """Compile the model of one variant."""
        return self.spec(**params).compile()

    def keyframe_index(self, model: mujoco.MjModel) -> int:
        """Index of the recipe's keyframe in ``model``; -1 for the reference state."""
        key = self.keyframe
        if key is None:
            return -1
        index = key if isinstance(key, int) else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, key)
        if not 0 <= index < model.nkey:
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, i) for i in range(model.nkey)]
            raise ValueError(f"recipe keyframe {key!r} is not in the model; its keyframes are {names}")
        return int(index)
