"""A cheaper or different model of the same scene, and how its states map to the original's.

:class:`Variant` is what every model transformation of mjflex returns (fidelity reduction in
:mod:`mjflex.variants.reduce`, MuJoCo-native alternatives such as welds or joint springs in
:mod:`mjflex.variants.alternatives`) and what the speed/accuracy study compares against the full model.
The study only relies on the fields below, so any user-built variant can be compared too.

The helpers here are shared by the builders: :func:`source_spec` turns what the user has (a
model file, an ``MjSpec``, or the ``MjModel`` last loaded from XML) into an editable spec, and
:class:`PoseFit` is the generic ``state_from``: it finds the variant's ``qpos`` / ``qvel`` that
put its bodies where the source's bodies are, by Gauss-Newton on the body poses.
"""

import functools
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np
import scipy.linalg

from ..mjcf import convert, elements
from ..mjcf.schema import PLUGIN, RECORD
from ..mjcf.spec import compile_spec
from ..native import library
from ..runtime.flexures import Flexures


class VariantNotApplicableError(Exception):
    """A variant builder has nothing to build for this model; the message says why."""


@dataclass
class Variant:
    """A model of the same scene as a source model, with the maps that relate the two.

    Attributes
    ----------
    name : str
        Short label for tables and plots, e.g. ``"weld"`` or ``"reduced(2000 Hz)"``.
    model : mujoco.MjModel
        The compiled variant. It may hold mjflex elements (the study then builds a
        :class:`mjflex.Flexures` for it) or none.
    report : str
        What was changed, and what the variant cannot represent (one line per change).
    body_map : dict[str, tuple[str, numpy.ndarray]]
        For every named body of the source model: ``(name of the variant body that carries
        it, X_VS)`` where ``X_VS`` is the 4x4 homogeneous pose of the source body's frame in
        that variant body's frame (identity for bodies kept as they are; a fixed offset for
        bodies merged into another one).
    state_from : callable
        ``state_from(source_model, source_data) -> (qpos, qvel)``: the variant's state that
        puts its bodies at the source's body poses and velocities (read from ``source_data``
        after ``mj_forward``), so both can start from the same initial condition.
    details : dict
        Machine-readable counterpart of ``report`` (JSON-serializable).
    spec : mujoco.MjSpec or None
        The spec the variant was compiled from (``spec.to_xml()`` saves it as a model file).

    Examples
    --------
    :func:`mjflex.reduce`, :func:`mjflex.weld_variant`, :func:`mjflex.pseudo_rigid_body_variant` and
    :func:`mjflex.bushing_variant` return one; here a block on a leaf spring, its element replaced by one joint:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    >>> variant = mjflex.pseudo_rigid_body_variant(spec)
    >>> variant.name, variant.model.nv, variant.body_map["block"][0]
    ('pseudo-rigid-body', 1, 'block')
    >>> source = spec.compile()
    >>> data = mujoco.MjData(source)
    >>> mujoco.mj_forward(source, data)
    >>> qpos, qvel = variant.state_from(source, data)  # the variant's state at the source's body poses
    >>> qpos.shape, qvel.shape
    ((1,), (1,))
    """

    name: str
    model: mujoco.MjModel
    report: str
    body_map: dict[str, tuple[str, np.ndarray]]
    state_from: Callable[[mujoco.MjModel, mujoco.MjData], tuple[np.ndarray, np.ndarray]]
    details: dict = field(default_factory=dict)  # machine-readable counterpart of ``report``
    spec: "mujoco.MjSpec | None" = None

    @property
    def has_flexures(self) -> bool:
        """Whether the variant still holds mjflex elements (then it needs a :class:`mjflex.Flexures`)."""
        names = (mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_TEXT, i) or "" for i in range(self.model.ntext))
        return any("mjflex:" in n for n in names) or bool(library.plugin_instances(self.model))


# ---------------------------------------------------------------------------------------- sources


def source_spec(source) -> mujoco.MjSpec:
    """An editable copy of a source model.

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        A model file, a spec (copied, never modified), or the ``MjModel`` that was compiled
        last from XML (MuJoCo keeps that XML; ``mj_saveLastXML`` refuses any other model).
    """
    if isinstance(source, mujoco.MjSpec):
        return convert.copy_spec(source)
    if isinstance(source, str | os.PathLike):
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise FileNotFoundError(f"model file {path!r} not found; pass the path of an MJCF file")
        return mujoco.MjSpec.from_file(path)
    if isinstance(source, mujoco.MjModel):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "source.xml")
            try:
                mujoco.mj_saveLastXML(path, source)
            except Exception as exc:  # MuJoCo raises ValueError or FatalError depending on the cause
                raise TypeError(
                    f"cannot recover the model file of this MjModel ({exc}); pass the MJCF path or the MjSpec "
                    "instead of the compiled model"
                ) from None
            return mujoco.MjSpec.from_file(path)
    raise TypeError(f"source must be a model file path, an MjSpec or an MjModel; got {type(source).__name__}")


def source_elements(source, verb) -> tuple:
    """``(spec, model, flex)`` of ``source`` (:func:`source_spec`, compiled, its :class:`mjflex.Flexures`); ValueError
    when it has no element (nothing to ``verb``)."""
    spec = source_spec(source)
    model = compile_spec(spec, why=None)
    flex = Flexures(model)
    if not len(flex):
        raise ValueError(f"the model has no mjflex elements: there is nothing to {verb}")
    return spec, model, flex


def keeps_element_kinds(builder):
    """Let a variant builder written for text records take plugin elements too, and keep their form.

    The source's ``mjflex.flexure`` instances become text records of a copy
    (:func:`mjflex.mjcf.convert.plugins_to_records`, lossless), the builder runs on it, and the
    elements the variant keeps are written back as plugin instances (its model compiled again,
    its ``state_from`` rebuilt), so a variant of a plugin model is a plugin model. Sources
    without plugin elements go to the builder unchanged.
    """

    @functools.wraps(builder)
    def build(source, *args, **kwargs):
        spec = source_spec(source)
        if not any(e.kind == PLUGIN for e in elements.spec_elements(spec)):
            return builder(source, *args, **kwargs)
        plugins = convert.plugins_to_records(spec)
        return restore_kinds(builder(spec, *args, **kwargs), plugins)

    return build


def restore_kinds(variant, plugins) -> "Variant":
    """``variant`` with those of the elements ``plugins`` it still holds written as plugin instances again."""
    if variant.spec is None:
        return variant
    kept = [e.name for e in elements.spec_elements(variant.spec) if e.kind == RECORD and e.name in set(plugins)]
    if not kept:
        return variant
    convert.records_to_plugins(variant.spec, kept)
    variant.model = compile_spec(variant.spec, why=None)
    if isinstance(variant.state_from, PoseFit):
        variant.state_from = PoseFit(variant.model, variant.body_map, constraints=variant.state_from.constraints)
    return variant


def body_names(model) -> list[str]:
    """Names of the bodies of ``model`` by id (``""`` for unnamed ones; id 0 is ``"world"``)."""
    return [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or "" for i in range(model.nbody)]


def reference_poses(model) -> tuple[np.ndarray, np.ndarray]:
    """World positions ``(nbody, 3)`` [m] and rotations ``(nbody, 3, 3)`` of the bodies at ``qpos0``."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return data.xpos.copy(), data.xmat.reshape(-1, 3, 3).copy()


def homogeneous(R, p) -> np.ndarray:
    """4x4 homogeneous transform from a rotation ``(3, 3)`` and a translation ``(3,)``."""
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = R, p
    return X


def identity_body_map(model) -> dict[str, tuple[str, np.ndarray]]:
    """``body_map`` of a variant that keeps every named body as it is."""
    return {n: (n, np.eye(4)) for n in body_names(model)[1:] if n}


# ---------------------------------------------------------------------------------------- states


def _rotation_log(R) -> np.ndarray:
    """Rotation vector of ``R`` (3,) [rad], robust near 0 and pi."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).ravel())
    v = np.empty(3)
    mujoco.mju_quat2Vel(v, q, 1.0)
    return v


def equality_rows(model, data) -> tuple[np.ndarray, np.ndarray]:
    """Residual ``(n,)`` and Jacobian ``(n, nv)`` of the equality constraints at ``data.qpos``.

    Runs ``mj_fwdPosition`` on ``data``; rows in MuJoCo's order (``efc_pos``, ``efc_J``).
    """
    if model.neq == 0:
        return np.zeros(0), np.zeros((0, model.nv))
    mujoco.mj_fwdPosition(model, data)
    rows = np.nonzero(data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)[0]
    G = np.zeros((data.nefc, model.nv))
    if mujoco.mj_isSparse(model):
        mujoco.mju_sparse2dense(G, data.efc_J, data.efc_J_rownnz, data.efc_J_rowadr, data.efc_J_colind)
    else:
        G[:] = data.efc_J.reshape(data.nefc, model.nv)
    return data.efc_pos[rows].copy(), G[rows]


def spatial_inertia(model, data, body, point) -> np.ndarray:
    """6x6 inertia ``(..., [omega; v_point])`` of ``body`` about ``point`` (world axes), kinetic energy
    ``1/2 V^T Phi V`` for the body's angular velocity and the velocity of its point at ``point``."""
    mass = model.body_mass[body]
    R = data.ximat[body].reshape(3, 3)
    r = data.xipos[body] - point
    rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    Phi = np.zeros((6, 6))
    Phi[:3, :3] = R @ np.diag(model.body_inertia[body]) @ R.T - mass * rx @ rx
    Phi[:3, 3:], Phi[3:, :3], Phi[3:, 3:] = mass * rx, -mass * rx, mass * np.eye(3)
    return Phi


class PoseFit:
    """``state_from`` for any variant: the state that puts its bodies at the source's poses.

    For every named source body ``S`` with an entry ``(V, X_VS)`` in ``body_map``, the frame
    ``X_WV X_VS`` carried by variant body ``V`` should coincide with ``S``'s frame and move with
    its spatial velocity. The variant's ``qpos`` is found by Gauss-Newton on these pose
    residuals (world-frame rotation vector and position of each frame origin; Jacobians from
    ``mj_jac``; integrated with ``mj_integratePos`` so that ball and free joints stay on their
    manifolds) from ``qpos0`` with the joints both models have by name at the source's values, and
    ``qvel`` by least squares on the frame velocities. The
    variant's own equality constraints (e.g. loop closures) are imposed exactly on both
    (unless ``constraints=False``).

    Both fits are weighted by the source bodies' spatial inertias (about their frame
    origins): the velocity fit then keeps the source's generalized momentum, ``sum_S J_S^T
    Phi_S (J_S qvel - V_S) = 0``. This matters when the source state moves directions the
    variant holds rigid (e.g. one body kicked while its stiff neighbours are at rest): the
    variant gets the motion its slow modes would take from that impulse, as the full model
    does once its stiff directions have rung out. When the variant can represent the source's
    state the fit is exact to round-off; ``last_residual`` says how far off it is otherwise.

    Parameters
    ----------
    model : mujoco.MjModel
        The variant.
    body_map : dict
        As in :class:`Variant`.
    constraints : bool
        Impose the variant's equality constraints (rigid loop closures); False for variants
        whose equalities are soft springs (matched welds), which the fit must not freeze.
    """

    def __init__(self, model, body_map, *, constraints=True, iterations=30, tol=1e-13):
        self.model = model
        self.constraints = constraints
        ids = {n: i for i, n in enumerate(body_names(model))}
        self._pairs = []
        for source_name, (variant_name, X_VS) in body_map.items():
            if variant_name not in ids:
                raise ValueError(f"body_map: variant body {variant_name!r} (for {source_name!r}) is not in the variant")
            self._pairs.append((source_name, ids[variant_name], np.asarray(X_VS, dtype=float)))
        self.iterations, self.tol = iterations, tol
        self.last_residual = 0.0
        self._data = mujoco.MjData(model)

    def _targets(self, source_model, source_data):
        """(variant body, X_VS, target X_WS, target [omega; v] of S's origin, weight Phi_S)."""
        ids = {n: i for i, n in enumerate(body_names(source_model))}
        targets = []
        for source_name, vid, X_VS in self._pairs:
            sid = ids.get(source_name)
            if sid is None:
                raise ValueError(f"source body {source_name!r} of the body map is not in the source model")
            X_WS = homogeneous(source_data.xmat[sid].reshape(3, 3), source_data.xpos[sid])
            vel = np.empty(6)  # [omega; v] of the source body's frame origin, world axes
            mujoco.mj_objectVelocity(source_model, source_data, mujoco.mjtObj.mjOBJ_XBODY, sid, vel, 0)
            Phi = spatial_inertia(source_model, source_data, sid, source_data.xpos[sid])
            targets.append((vid, X_VS, X_WS, vel, Phi))
        return targets

    def _residual_jacobian(self, targets):
        m, d = self.model, self._data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        r = np.empty(6 * len(targets))
        J = np.empty((6 * len(targets), m.nv))
        for k, (vid, X_VS, X_WS, _, _) in enumerate(targets):
            X = homogeneous(d.xmat[vid].reshape(3, 3), d.xpos[vid]) @ X_VS
            r[6 * k : 6 * k + 3] = _rotation_log(X_WS[:3, :3] @ X[:3, :3].T)
            r[6 * k + 3 : 6 * k + 6] = X_WS[:3, 3] - X[:3, 3]
            mujoco.mj_jac(m, d, J[6 * k + 3 : 6 * k + 6], J[6 * k : 6 * k + 3], X[:3, 3], vid)
        return r, J

    def _equalities(self):
        if not self.constraints:
            return np.zeros(0), np.zeros((0, self.model.nv))
        return equality_rows(self.model, self._data)

    @staticmethod
    def _weighted_solve(J, W, rhs, G=None, g=None):
        """argmin ``(J x - rhs)^T W (J x - rhs)`` subject to ``G x = g`` (least squares where redundant)."""
        A = J.T @ W @ J
        A += np.eye(len(A)) * 1e-12 * max(np.abs(np.diag(A)).max(initial=0.0), 1e-300)
        b = J.T @ W @ rhs
        if G is None or len(G) == 0:
            return np.linalg.lstsq(A, b, rcond=None)[0]
        scale = np.sqrt(np.abs(np.diag(A)).max(initial=1.0) / max(np.abs(G).max(), 1e-300))
        n = len(A)
        kkt = np.block([[A, scale * G.T], [scale * G, np.zeros((len(G), len(G)))]])
        return np.linalg.lstsq(kkt, np.concatenate([b, scale * g]), rcond=None)[0][:n]

    def _seed(self, source_model, source_data):
        """Start from ``qpos0`` with every joint that both models have (same name and type) at the source's value."""
        m, d = self.model, self._data
        d.qpos[:] = m.qpos0
        for j in range(m.njnt):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            s = mujoco.mj_name2id(source_model, mujoco.mjtObj.mjOBJ_JOINT, name) if name else -1
            if s >= 0 and source_model.jnt_type[s] == m.jnt_type[j]:
                n = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}.get(int(m.jnt_type[j]), 1)
                a, b = m.jnt_qposadr[j], source_model.jnt_qposadr[s]
                d.qpos[a : a + n] = source_data.qpos[b : b + n]

    def __call__(self, source_model, source_data):
        targets = self._targets(source_model, source_data)
        m, d = self.model, self._data
        self._seed(source_model, source_data)
        if not targets or m.nv == 0:
            return d.qpos.copy(), np.zeros(m.nv)
        W = scipy.linalg.block_diag(*[t[4] for t in targets])
        for _ in range(self.iterations):
            r, J = self._residual_jacobian(targets)
            e, G = self._equalities()
            if max(np.abs(r).max(), np.abs(e).max(initial=0.0)) < self.tol:
                break
            mujoco.mj_integratePos(m, d.qpos, self._weighted_solve(J, W, r, G, -e), 1.0)
        r, J = self._residual_jacobian(targets)
        e, G = self._equalities()
        self.last_residual = float(max(np.abs(r).max(), np.abs(e).max(initial=0.0)))
        qvel = self._weighted_solve(J, W, np.concatenate([t[3] for t in targets]), G, np.zeros(len(G)))
        return d.qpos.copy(), qvel


def stops_lines(flex, fate: str, rest_fate: str | None = None) -> list[str]:
    """Report lines for the elements of ``flex`` with end stops or a rest pose, saying what a variant does with them
    (never dropped silently; :class:`mjflex.Stops`); ``rest_fate``: what it does with a rest pose (default: only an
    element kept whole keeps it)."""
    rest_fate = rest_fate or (
        "is kept by an element kept whole only; a MuJoCo-native replacement (weld, bushing, joints) is at rest where "
        "the model compiled it"
    )
    pairs = list(zip(flex.names, flex.records, strict=True))
    return [f"{name}: its end stops {fate}" for name, rec in pairs if rec.stops] + [
        f"{name}: its rest pose (a preload) {rest_fate}" for name, rec in pairs if rec.rest is not None
    ]


def polynomial_terms_lines(flex, fate: str) -> list[str]:
    """Report lines for the elements of ``flex`` with polynomial terms, saying what a variant does with them.

    Variants built from MuJoCo joints, welds or planar records are linear in the elements they
    replace: they hold the stiffness at rest ``K`` (which the terms of :func:`mjflex.polynomial_basis`
    leave unchanged) and not the terms; the report must say so rather than drop them silently.
    """
    return [
        f"{name}: its polynomial terms (order {rec.order}, {len(rec.terms)} terms) {fate}"
        for name, rec in zip(flex.names, flex.records, strict=True)
        if rec.terms is not None
    ]
