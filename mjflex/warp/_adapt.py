"""What :func:`mjflex.warp.put_model` adapts on its copy of a model for MuJoCo Warp, and what it refuses.

MuJoCo Warp 4.0.0 accepts only the compiler's automatic sleep policies, refuses the autoreset
disable flag, ignores ``mjflex.flexure`` plugin instances (and its ``put_model`` fails on them:
:func:`plugin_arrays_sized` works around that), and drops plugin instances attached to nothing it
runs. Each function returns the lines that say what it changed (``WarpFlexures.adaptations``).
"""

import contextlib
import threading
import warnings

import mujoco

from . import _mjflex

_SLEEP = mujoco.mjtSleepPolicy
_AUTO_OF = {int(_SLEEP.mjSLEEP_NEVER): int(_SLEEP.mjSLEEP_AUTO_NEVER),
            int(_SLEEP.mjSLEEP_ALLOWED): int(_SLEEP.mjSLEEP_AUTO_ALLOWED),
            int(_SLEEP.mjSLEEP_INIT): int(_SLEEP.mjSLEEP_AUTO_ALLOWED)}  # fmt: skip


_PATCH_LOCK = threading.Lock()


@contextlib.contextmanager
def plugin_arrays_sized(model):
    """Work around MuJoCo Warp 4.0.0's ``put_model`` on models with non-geom plugin instances.

    It keeps only the geom plugins' instances in ``plugin`` / ``plugin_attr`` but sizes those
    arrays by the model's ``nplugin``, and fails ("cannot reshape array of size 0"). While it runs,
    the arrays of the ``nplugin`` dimension are sized by the instances it kept (``nplugin`` is read
    nowhere else in MuJoCo Warp 4.0.0). Only applied to models that have such instances;
    ``tests/test_warp.py`` checks that plain MuJoCo Warp still needs it.
    """
    if model.nplugin == int((model.geom_plugin >= 0).sum()):
        yield
        return
    from mujoco_warp._src import io  # MuJoCo Warp's private io: only for the work-around, where it applies

    original = io._create_array

    def create_array(data, spec, sizes, batch_size=1):
        if getattr(spec, "shape", ())[:1] == ("nplugin",):
            sizes = {**sizes, "nplugin": len(data)}
        return original(data, spec, sizes, batch_size)

    with _PATCH_LOCK:
        io._create_array = create_array
        try:
            yield
        finally:
            io._create_array = original


def _name(model, objtype, i, fallback):
    return mujoco.mj_id2name(model, objtype, int(i)) or f"{fallback} #{int(i)}"


def check_plugins(model) -> list[str]:
    ours = set(_mjflex.mjflex_instances(model))
    # geom plugins MuJoCo Warp runs; those of bodies, actuators and sensors it refuses itself, with its own message
    attached = {int(p) for a in (model.geom_plugin, model.body_plugin, model.actuator_plugin, model.sensor_plugin)
                for p in a if p >= 0}  # fmt: skip
    others = [i for i in range(model.nplugin) if i not in ours and i not in attached]
    if others:
        names = ", ".join(repr(_name(model, mujoco.mjtObj.mjOBJ_PLUGIN, i, "instance")) for i in others[:5])
        raise NotImplementedError(
            f"mjflex.warp.put_model: plugin instance(s) {names} are neither mjflex.flexure elements nor attached to "
            "a geom, body, actuator or sensor; MuJoCo Warp would drop them silently (their forces or effects would be "
            "lost). Remove them for MuJoCo Warp, or simulate the model with MuJoCo"
        )
    if not ours:
        return []
    return [f"the {len(ours)} mjflex.flexure plugin instances, which MuJoCo Warp ignores, are computed by mjflex's "
            "passive callback (the same elements as the C plugin)"]  # fmt: skip


def adapt_sleep(model, table) -> list[str]:
    policy = model.tree_sleep_policy
    sleep_on = bool(model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP)
    changed = {}
    for tree, value in enumerate(policy):
        value = int(value)
        if value not in _AUTO_OF:
            continue
        root = _name(model, mujoco.mjtObj.mjOBJ_BODY, model.tree_bodyadr[tree], "body")
        if value == int(_SLEEP.mjSLEEP_INIT) and sleep_on:
            raise NotImplementedError(
                f"mjflex.warp.put_model: the tree of body '{root}' starts asleep (sleep=\"init\"), which MuJoCo Warp "
                'does not support; use sleep="allowed" for MuJoCo Warp'
            )
        changed.setdefault(_SLEEP(value).name, []).append(root)
        policy[tree] = _AUTO_OF[value]
        if sleep_on and value != int(_SLEEP.mjSLEEP_NEVER) and tree in table.joined_trees:
            warnings.warn(
                f"mjflex.warp: flexure '{table.joined_trees[tree]}' joins the tree of body '{root}', which may sleep: "
                'a sleeping tree ignores forces, so the element\'s force is lost while it sleeps. Set sleep="never" '
                "on its root body, or disable sleeping",
                UserWarning,
                stacklevel=3,
            )
    out = []
    for name, roots in changed.items():
        more = f" and {len(roots) - 3} more" if len(roots) > 3 else ""
        new = _SLEEP(_AUTO_OF[int(getattr(_SLEEP, name))]).name
        why = "" if sleep_on else " (sleeping is off in this model: no effect)"
        out.append(f"sleep policy {name} of the trees of {', '.join(roots[:3])}{more} set to {new}, which MuJoCo "
                   f"Warp accepts and which acts the same{why}")  # fmt: skip
    return out


def adapt_flags(model) -> list[str]:
    autoreset = int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    if not model.opt.disableflags & autoreset:
        return []
    model.opt.disableflags &= ~autoreset
    return ["the autoreset disable flag, which MuJoCo Warp refuses, cleared: MuJoCo Warp never resets a world "
            "(what the flag asks for); a diverged world is flagged by mjflex.warp.divergences"]  # fmt: skip
