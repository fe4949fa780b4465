"""Modal analysis of a model with flexures, summarised by how each body moves."""

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from ..analysis.linearize import normal_modes

RIGID_TOL_HZ = 1e-3


@dataclass
class ModeSummary:
    """One normal mode, described by body motion."""

    index: int
    frequency_hz: float
    rigid: bool
    top_bodies: list  # [(body name, share of the mode's kinetic energy)], largest first
    moving_share: float  # kinetic-energy share of the moving body (e.g. the cylinder)
    axial_fraction: float  # of the moving body's motion relative to the reference body
    relative_amplitude: float  # |relative velocity| / largest body velocity

    @property
    def is_axial_translation(self) -> bool:
        """The moving body translates along the reference body's z axis relative to it."""
        return not self.rigid and self.axial_fraction > 0.99 and self.relative_amplitude > 0.1


def _body_motion(model, data, qvel):
    data.qvel[:] = qvel
    mujoco.mj_fwdVelocity(model, data)
    velocity = np.zeros((model.nbody, 6))  # per body: angular, then linear (world axes)
    for b in range(model.nbody):
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, b, velocity[b], 0)
    w, v = velocity[:, :3], velocity[:, 3:]
    R = data.ximat.reshape(-1, 3, 3)
    w_local = np.einsum("bji,bj->bi", R, w)
    ke = 0.5 * model.body_mass * (v**2).sum(1) + 0.5 * (model.body_inertia * w_local**2).sum(1)
    return v, w, ke


def describe_modes(model, freq, modes, *, count=12, reference="base", moving="cylinder"):
    """Summaries of the first ``count`` modes (see :class:`ModeSummary`).

    ``axial_fraction`` is ``(v_rel . z)^2 / (|v_rel|^2 + (l |w_rel|)^2)`` for the velocity of
    ``moving``'s centre of mass relative to ``reference``'s, with ``z`` the reference body's axis
    and ``l`` the radius of gyration of ``moving``; 1 means a pure axial translation.
    """
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    mujoco.mj_fwdPosition(model, data)
    ids = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in (reference, moving)}
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "world" for b in range(model.nbody)]
    axis = data.xmat[ids[reference]].reshape(3, 3)[:, 2]
    gyration = np.sqrt(model.body_inertia[ids[moving]].max() / model.body_mass[ids[moving]])
    out = []
    for k in range(min(count, len(freq))):
        v, w, ke = _body_motion(model, data, modes[:, k])
        share = ke / max(ke.sum(), np.finfo(float).tiny)
        order = np.argsort(share)[::-1][:3]
        v_rel = v[ids[moving]] - v[ids[reference]]
        w_rel = w[ids[moving]] - w[ids[reference]]
        denom = v_rel @ v_rel + gyration**2 * (w_rel @ w_rel)
        out.append(ModeSummary(
            index=k, frequency_hz=float(freq[k]), rigid=bool(freq[k] < RIGID_TOL_HZ),
            top_bodies=[(names[b], round(float(share[b]), 3)) for b in order],
            moving_share=float(share[ids[moving]]),
            axial_fraction=float((v_rel @ axis) ** 2 / denom) if denom > 0 else 0.0,
            relative_amplitude=float(np.linalg.norm(v_rel) / max(np.linalg.norm(v, axis=1).max(), 1e-300)),
        ))  # fmt: skip
    return out


def guide_report(model, flex, *, count=12):
    """Normal modes of a guide and the verdict: is the lowest non-rigid mode the axial translation?

    Returns a dict with ``modes`` (list of :class:`ModeSummary` as dicts), ``n_rigid``,
    ``guide_mode`` (index of the lowest non-rigid mode), ``guide_is_axial`` and
    ``separation`` (its frequency ratio to the next mode).
    """
    freq, shapes = normal_modes(model, flex)
    summary = describe_modes(model, freq, shapes, count=count)
    n_rigid = int(np.sum(freq < RIGID_TOL_HZ))
    first = summary[n_rigid]
    return {
        "modes": [asdict(s) | {"is_axial_translation": s.is_axial_translation} for s in summary],
        "n_rigid": n_rigid,
        "guide_mode": n_rigid,
        "guide_is_axial": first.is_axial_translation,
        "guide_frequency_hz": first.frequency_hz,
        "separation": float(freq[n_rigid + 1] / freq[n_rigid]),
        "highest_frequency_hz": float(freq[-1]),
    }
