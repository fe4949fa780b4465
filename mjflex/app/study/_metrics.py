"""What the study compares: poses of tracked bodies or sites, energy, first natural frequencies.

A candidate is compared with the reference at common sample times. Poses are read through a
variant's ``body_map`` so that a model with other bodies (merged, re-jointed) is compared in the
source model's terms.
"""

from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from ...analysis.advice import first_order
from ...analysis.linearize import Options, linearize
from ...variants.variant import homogeneous

#: Eigenvalues of ``M^-1 K`` below this fraction of the largest count as rigid-body modes. The
#: finite-difference noise of the linearization is ~1e-16 of the largest eigenvalue (measured on
#: ARCADE: rigid eigenvalues |lambda| < 7e-7 against lambda_max = 7.5e9), so 1e-12 separates them
#: from elastic modes 1e6 times softer than the stiffest one.
RIGID_EIGENVALUE_RTOL = 1e-12
#: Below these motion ranges (relative to the model extent, and in rad) a pose component counts as
#: not moving and is left out of the relative error (dividing by round-off would be meaningless).
POSITION_FLOOR_RTOL = 1e-10
ROTATION_FLOOR = 1e-10


def pose_matrix(pos, quat):
    """4x4 homogeneous pose from a position (3,) [m] and a w-first unit quaternion (4,)."""
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    return homogeneous(R.reshape(3, 3), pos)


@dataclass(frozen=True)
class TrackedItem:
    """A body or site of the source model whose pose the study compares.

    ``body`` is the source body carrying it and ``X_BI`` the item's fixed pose in that body's
    frame (4x4; identity for a body).
    """

    label: str
    body: str
    X_BI: np.ndarray


class PoseReader:
    """Poses of the tracked items, relative to a frame body, read from a (variant) model's data.

    Parameters
    ----------
    model : mujoco.MjModel
        The model whose ``data`` will be read (the source model or a variant).
    body_map : dict[str, tuple[str, numpy.ndarray]] or None
        ``source body -> (variant body, X_VS)`` as in :class:`mjflex.variants.variant.Variant`; None
        for the source model itself.
    items : list of TrackedItem
    frame : str or None
        Source body whose frame the poses are expressed in; None for the world frame.
    """

    def __init__(self, model, body_map, items, frame):
        def locate(source_body):
            name, X_VS = (source_body, np.eye(4)) if body_map is None else body_map[source_body]
            bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if bid < 0:
                raise ValueError(f"body_map sends source body {source_body!r} to {name!r}, which the model lacks")
            return bid, np.asarray(X_VS, dtype=float)

        located = [locate(item.body) for item in items]
        self._ids = np.array([b for b, _ in located], dtype=int)
        self._X = np.stack([X_VS @ item.X_BI for (_, X_VS), item in zip(located, items, strict=True)])
        self._frame = None if frame is None else locate(frame)

    def read(self, data):
        """Positions ``(n, 3)`` [m] and rotation matrices ``(n, 3, 3)`` of the items in the frame."""
        R_WV = data.xmat[self._ids].reshape(-1, 3, 3)
        R = R_WV @ self._X[:, :3, :3]
        p = data.xpos[self._ids] + np.einsum("nij,nj->ni", R_WV, self._X[:, :3, 3])
        if self._frame is None:
            return p, R
        fid, X_VS = self._frame
        R_WF = data.xmat[fid].reshape(3, 3) @ X_VS[:3, :3]
        p_WF = data.xpos[fid] + data.xmat[fid].reshape(3, 3) @ X_VS[:3, 3]
        return (p - p_WF) @ R_WF, np.einsum("ji,njk->nik", R_WF, R)


@dataclass
class Trajectory:
    """Samples of one run at the study's sample times.

    ``p`` (nt, n, 3) [m] and ``R`` (nt, n, 3, 3) are the tracked items' poses in the frame;
    ``energy`` (nt,) is MuJoCo's kinetic + potential energy plus the elements' elastic energy
    [J]; ``kinetic`` and ``elastic`` (nt,) are its parts used for scales.
    """

    time: np.ndarray
    p: np.ndarray
    R: np.ndarray
    energy: np.ndarray
    kinetic: np.ndarray
    elastic: np.ndarray

    def __len__(self):
        return len(self.time)


def rotation_angle(R1, R2):
    """Angle [rad] of ``R1^T R2`` for stacks ``(..., 3, 3)``; accurate for tiny angles.

    ``|R1 - R2|_F = 2 sqrt(2) sin(angle / 2)``, which keeps full relative precision near 0 where
    ``acos((trace - 1) / 2)`` loses half the digits.
    """
    d = np.linalg.norm(R1 - R2, axis=(-2, -1))
    return 2.0 * np.arcsin(np.clip(d / (2.0 * np.sqrt(2.0)), 0.0, 1.0))


@dataclass
class Scales:
    """Ranges of the reference's motion and energy that errors are relative to."""

    position: float  # largest displacement of a tracked item from its start [m]; 0 if below the floor
    rotation: float  # largest rotation of a tracked item from its start [rad]; 0 if below the floor
    energy: float  # largest swing of the kinetic or elastic energy [J]

    @classmethod
    def of(cls, ref: Trajectory, extent: float):
        pos = float(np.max(np.linalg.norm(ref.p - ref.p[:1], axis=-1), initial=0.0))
        rot = float(np.max(rotation_angle(ref.R, ref.R[:1]), initial=0.0))
        energy = max(float(np.ptp(ref.kinetic)), float(np.ptp(ref.elastic)), np.finfo(float).tiny)
        return cls(
            position=pos if pos > POSITION_FLOOR_RTOL * extent else 0.0,
            rotation=rot if rot > ROTATION_FLOOR else 0.0,
            energy=energy,
        )


@dataclass
class Errors:
    """Errors of a run against the reference over all sample times (relative, dimensionless).

    ``position``: largest distance of a tracked item from its reference position, over the
    largest displacement in the reference; ``rotation`` likewise for orientations; ``pose`` the
    larger of the two (the study's headline error); ``energy``: largest deviation of the total
    energy from the reference's, over the reference's largest kinetic or elastic energy swing.
    """

    pose: float
    position: float | None
    rotation: float | None
    energy: float

    @classmethod
    def between(cls, run: Trajectory, ref: Trajectory, scales: Scales):
        if len(run) != len(ref) or not np.allclose(run.time, ref.time, rtol=0, atol=1e-9 * max(ref.time[-1], 1e-9)):
            raise ValueError("trajectories are sampled at different times; they cannot be compared")
        pos = rot = None
        if scales.position > 0:
            pos = float(np.max(np.linalg.norm(run.p - ref.p, axis=-1))) / scales.position
        if scales.rotation > 0:
            rot = float(np.max(rotation_angle(run.R, ref.R))) / scales.rotation
        parts = [e for e in (pos, rot) if e is not None]
        if not parts:  # nothing moves relative to the frame: report the absolute position error
            parts = [float(np.max(np.linalg.norm(run.p - ref.p, axis=-1)))]
        energy = float(np.max(np.abs(run.energy - ref.energy))) / scales.energy
        return cls(pose=max(parts), position=pos, rotation=rot, energy=energy)


class Linearization(NamedTuple):
    """Natural frequencies and the fastest rate of a model linearized at rest."""

    elastic: np.ndarray  # non-rigid natural frequencies [Hz], ascending
    highest: float  # highest natural frequency [Hz] (0 without elastic modes)
    rate: float  # largest |eigenvalue| of the first-order system with damping [1/s]


def linearized_frequencies(model, flex, qpos, *, ctrl=None, act=None):
    """Natural frequencies [Hz] and fastest rate of a model linearized at ``qpos``, at rest.

    The model as MuJoCo steps it (:func:`mjflex.analysis.linearize.linearize` with everything on: the
    elements, joint springs, actuators at ``ctrl``/``act``, gravity and the soft constraints) gives
    ``A = M^-1 K``, whose eigenvalues are ``omega^2``, and ``D = M^-1 C``. This works for any model,
    with or without mjflex elements (for those alone it agrees with :func:`mjflex.normal_modes` to
    ~1e-10, tested).

    Returns
    -------
    Linearization
        ``elastic``: non-rigid frequencies [Hz], ascending (eigenvalues of ``A`` below
        ``RIGID_EIGENVALUE_RTOL`` of the largest are rigid-body modes and dropped); ``highest``:
        the highest frequency [Hz]; ``rate``: the largest ``|lambda|`` of
        ``[[0, I], [-A, -D]]`` [1/s], which bounds explicit time steps (``|lambda| h`` below about
        2 for Euler, 2.8 for RK4) also where damping, not stiffness, is the fastest effect.
    """
    if not model.nv:
        return Linearization(np.zeros(0), 0.0, 0.0)
    base = mujoco.MjData(model)
    base.qpos[:] = qpos
    if ctrl is not None:
        base.ctrl[:] = ctrl
    if act is not None:
        base.act[:] = act
    lin = linearize(model, flex, base, Options(True, "spring", True, True), damping=True, dynamics=True)
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(lin.M, lin.K)).real)
    top = float(lam[-1])
    rate = float(np.max(np.abs(first_order(lin)[0])))
    if not top > 0:
        return Linearization(np.zeros(0), 0.0, rate)
    elastic = lam[lam > RIGID_EIGENVALUE_RTOL * top]
    return Linearization(np.sqrt(elastic) / (2.0 * np.pi), float(np.sqrt(top) / (2.0 * np.pi)), rate)


def frequency_error(freq, ref_freq, count):
    """Largest relative difference of the first ``count`` elastic frequencies (None if none).

    Frequencies are paired in ascending order, so a model that lacks one of the reference's low
    modes (or adds one) below its highest shows a large error, as it should; a model with fewer
    elastic modes than ``count`` is compared on those it has (the study notes how many).
    """
    n = min(count, len(freq), len(ref_freq))
    if n == 0:
        return None
    return float(np.max(np.abs(np.asarray(freq[:n]) - ref_freq[:n]) / ref_freq[:n]))
