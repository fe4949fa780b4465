"""The passive-force provider: parse a model's flexures once, then add their forces every step."""

import difflib

import mujoco
import numpy as np

from ..core import validation
from ..core.transforms import twist_from_transform
from . import _callback, schema
from . import _kernels as k


class ModelError(ValueError):
    """A flexure element of a model is malformed; the message names the element and the fix."""


def _names(model, objtype, count):
    return [mujoco.mj_id2name(model, objtype, i) or "" for i in range(count)]


def _text_records(model):
    """``{element: json_data}`` of the model's ``mjflex:`` text records."""
    out = {}
    for i, name in enumerate(_names(model, mujoco.mjtObj.mjOBJ_TEXT, model.ntext)):
        if name.startswith(schema.PREFIX):
            adr, size = model.text_adr[i], model.text_size[i]
            out[name[len(schema.PREFIX) :]] = bytes(model.text_data[adr : adr + size - 1]).decode("utf-8")
    return out


def _dof_chain(model, body):
    """Dofs whose motion moves ``body``, from its own last dof to the root."""
    while body > 0 and model.body_dofnum[body] == 0:
        body = model.body_parentid[body]
    if body == 0:
        return []
    j, chain = model.body_dofadr[body] + model.body_dofnum[body] - 1, []
    while j >= 0:
        chain.append(int(j))
        j = model.dof_parentid[j]
    return chain


def _free_dofadr(model, body):
    """Dof address of a free joint that is the only joint of a child of the world, else -1."""
    if body > 0 and model.body_parentid[body] == 0 and model.body_jntnum[body] == 1:
        j = model.body_jntadr[body]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            return int(model.jnt_dofadr[j])
    return -1


class Flexures:
    """Visco-elastic flexure elements of a MuJoCo model and the passive forces they add.

    Parameters
    ----------
    model : mujoco.MjModel
        A model whose elements are written in its file as described in
        :mod:`mjflex.mj.schema` (sites ``E/a``, ``E/b`` and a text record ``mjflex:E``).
        All elements are parsed and validated here, once; a malformed one raises
        :class:`ModelError`.

    Notes
    -----
    ``install()`` (or ``with flex:``) adds the elements' generalized forces to
    ``data.qfrc_passive`` inside every ``mj_step`` / ``mj_forward`` of this model, for every
    integrator and any kinematic tree. The functions that read a ``data`` (``wrenches``,
    ``potential_energy``, ...) use its kinematics as they are (``site_xpos``, ``cvel``...), i.e.
    as of the last ``mj_forward`` or the start of the last ``mj_step``, like ``data.energy``.
    MuJoCo's ``spring`` / ``damper`` disable flags switch off the elastic / viscous parts.
    A provider is bound to this ``MjModel`` object; a copy of it (``copy.copy``, or the file
    loaded again) needs its own ``Flexures``. One provider per model can be installed at a time.

    Integrators: the forces enter every integrator explicitly, as external smooth forces
    (MuJoCo takes no user derivatives into its implicit updates), so the time step must resolve
    the stiffest element mode: about ``h < 2 / omega_max`` (Euler, implicit, implicitfast,
    discrete) and ``h < 2.8 / omega_max`` (RK4); see ``mjflex.mj.linearize.normal_modes``.
    Convergence is first order for the single-step integrators and fourth order for RK4
    (tested). Under ``discrete`` the velocity-stepping solve treats them like any applied force:
    first order, no position-implicit stabilization of the flexures, and ``qacc`` is the step
    map ``(v+ - v)/h``.
    """

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        texts = _text_records(model)
        self.names = tuple(texts)
        self._index = {name: i for i, name in enumerate(self.names)}
        self.records = [self._record(name, texts[name]) for name in self.names]
        self._build_tables()

    # ------------------------------------------------------------------ parsing

    def _error(self, element, problem, fix):
        return ModelError(f"flexure '{element}': {problem}. {fix}")

    def _record(self, element, data):
        try:
            rec = schema.parse_text(element, data)
        except ValueError as exc:
            raise self._error(element, f"text record '{schema.PREFIX}{element}' is malformed: {exc}", "Fix the JSON "
                              "data (see mjflex.mj.schema for the keys).") from None  # fmt: skip
        for key in ("K", "B"):
            M = getattr(rec, key)
            if M is None:
                continue
            try:
                validation.check_psd_matrix(M, key, M.shape[0], what="stiffness" if key == "K" else "damping")
            except ValueError as exc:
                raise self._error(element, str(exc).rstrip("."), "Fix its text record.") from None
        return rec

    def _site(self, element, name, all_sites):
        sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        if sid < 0:
            others = set(schema.site_names(element))
            close = difflib.get_close_matches(name, [s for s in all_sites if s not in others], n=3, cutoff=0.6)
            hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise self._error(
                element, f"site '{name}' not found",
                f"Add <site name=\"{name}\"/> at the element frame ({'body A' if name.endswith('/a') else 'body B'})"
                f" or rename the existing site.{hint}",
            )  # fmt: skip
        return sid

    def _build_tables(self):
        m, n = self.model, len(self.names)
        all_sites = _names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite)
        ref = mujoco.MjData(m)
        ref.qpos[:] = m.qpos0
        mujoco.mj_kinematics(m, ref)
        self._ints = np.zeros((n, k.NI), dtype=np.int64)
        self._floats = np.zeros((n, k.NF))
        chain = []
        for e, rec in enumerate(self.records):
            sa, sb = (self._site(rec.name, s, all_sites) for s in schema.site_names(rec.name))
            ba, bb = int(m.site_bodyid[sa]), int(m.site_bodyid[sb])
            if ba == bb:
                body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, ba) or f"#{ba}"
                fix = "Put site '/a' on one body and '/b' on the other (use 'world' to ground)."
                raise self._error(rec.name, f"both sites are on body '{body}'", fix)
            R0, p0 = self._rest_offset(rec.name, ref, sa, sb)
            row = self._ints[e]
            row[[k.SITE_A, k.SITE_B, k.BODY_A, k.BODY_B]] = sa, sb, ba, bb
            row[k.METHOD] = validation.METHOD_CODES[rec.method]
            row[k.ENABLED], row[k.VISCOUS] = rec.enabled, rec.viscous and rec.B is not None
            row[k.OFFSET] = not (np.array_equal(R0, np.eye(3)) and not p0.any())
            for body, free, c0, c1 in ((ba, k.FREE_A, k.CHAIN_A0, k.CHAIN_A1), (bb, k.FREE_B, k.CHAIN_B0, k.CHAIN_B1)):
                row[free] = _free_dofadr(m, body)
                dofs = [] if row[free] >= 0 else _dof_chain(m, body)
                row[c0], row[c1] = len(chain), len(chain) + len(dofs)
                chain.extend(dofs)
            K = schema.embed_planar(rec.K) if rec.planar else rec.K
            B = np.zeros((6, 6)) if rec.B is None else (schema.embed_planar(rec.B) if rec.planar else rec.B)
            self._floats[e, k.K_AT : k.K_AT + 36] = K.ravel()
            self._floats[e, k.B_AT : k.B_AT + 36] = B.ravel()
            self._floats[e, k.R0_AT : k.R0_AT + 9] = R0.ravel()
            self._floats[e, k.P0_AT : k.P0_AT + 3] = p0
        self._chain = np.array(chain + [0], dtype=np.int64)  # never empty: a valid address
        self._rootid = np.ascontiguousarray(m.body_rootid, dtype=np.int64)
        self._messages = [self._message(name) for name in self.names]
        self._message_addresses = np.array([np.frombuffer(b, np.uint8).ctypes.data for b in self._messages] or [0])

    def _rest_offset(self, element, ref, sa, sb):
        """Relative pose ``X_ab0`` of the sites at ``qpos0``; must be (numerically) identity."""
        R_a, R_b = ref.site_xmat[sa].reshape(3, 3), ref.site_xmat[sb].reshape(3, 3)
        R0 = R_a.T @ R_b
        p0 = R_a.T @ (ref.site_xpos[sb] - ref.site_xpos[sa])
        dist = float(np.linalg.norm(p0))
        angle = float(np.linalg.norm(twist_from_transform(R0, p0, check=False)[:3]))
        tol = schema.COINCIDENCE_RTOL * max(float(self.model.stat.extent), 1e-3)
        if dist > tol or angle > schema.COINCIDENCE_ANGLE:
            a, b = schema.site_names(element)
            raise self._error(
                element,
                f"sites '{a}' and '{b}' are {dist:.3g} m apart and {angle:.3g} rad apart at qpos0 "
                f"(tolerance {tol:.3g} m, {schema.COINCIDENCE_ANGLE:g} rad)",
                "Both frames must coincide in the reference configuration: place both at the same world "
                "pose (mjflex.add_flexure does this).",
            )
        return R0, p0

    def _message(self, element):
        name = self.model.names[: self.model.names.index(b"\x00")].decode() or "unnamed"
        text = (
            f"mjflex: flexure '{element}' of model '{name}' produced a non-finite wrench: the pose or velocity of "
            "its bodies is NaN/inf or the simulation diverged. Reduce the time step, or check the qpos/qvel you set."
        )
        return text.replace("%", "%%").encode() + b"\x00"

    # ------------------------------------------------------------------ installation

    def _slot_words(self):
        words = np.zeros(k.SLOT, dtype=np.int64)
        words[k.S_N] = len(self.names)
        words[k.S_INTS], words[k.S_FLOATS] = self._ints.ctypes.data, self._floats.ctypes.data
        words[k.S_CHAIN], words[k.S_NCHAIN] = self._chain.ctypes.data, len(self._chain)
        words[k.S_ROOTID] = self._rootid.ctypes.data
        words[k.S_NSITE], words[k.S_NBODY], words[k.S_NV] = self.model.nsite, self.model.nbody, self.model.nv
        words[k.S_MESSAGES] = self._message_addresses.ctypes.data
        return words

    def install(self) -> "Flexures":
        """Start adding this model's flexure forces in ``mj_step`` / ``mj_forward``."""
        if self.names:
            _callback.register(self, self._slot_words())
        return self

    def uninstall(self) -> None:
        """Stop; when no model is left, restore the passive callback that was there before."""
        _callback.unregister(self)

    @property
    def installed(self) -> bool:
        """Whether the forces are currently added (False if another callback replaced ours)."""
        return bool(self.names) and _callback.is_installed(self)

    def __enter__(self):
        return self.install()

    def __exit__(self, *exc):
        self.uninstall()

    def __len__(self):
        return len(self.names)

    def __repr__(self):
        return f"Flexures({len(self)} elements: {', '.join(self.names[:5])}{', ...' if len(self) > 5 else ''})"

    # ------------------------------------------------------------------ evaluation

    def _run(self, data, mode, out6=None, out1=None, qfrc=None):
        m = self.model
        if data.qpos.shape != (m.nq,) or data.site_xpos.shape != (m.nsite, 3):
            raise ValueError("data does not belong to this model (sizes differ); pass mujoco.MjData(flex.model)")
        flags = m.opt.disableflags
        status = k.flexure_loop(
            mode, self._ints, self._floats, self._chain, self._rootid, data.site_xpos, data.site_xmat, data.xpos,
            data.xmat, data.cvel, data.subtree_com, data.cdof,
            not flags & mujoco.mjtDisableBit.mjDSBL_SPRING, not flags & mujoco.mjtDisableBit.mjDSBL_DAMPER,
            np.zeros(0) if qfrc is None else qfrc, np.zeros((0, 6)) if out6 is None else out6,
            np.zeros(0) if out1 is None else out1,
        )  # fmt: skip
        if status >= 0:
            raise mujoco.FatalError(self._messages[status][:-1].decode().replace("%%", "%"))

    def _apply_in_callback(self, data):
        self._run(data, k.APPLY, qfrc=data.qfrc_passive)

    def index(self, name: str) -> int:
        """Row of element ``name`` in the per-element arrays."""
        try:
            return self._index[name]
        except KeyError:
            close = difflib.get_close_matches(name, self.names, n=3)
            raise KeyError(f"no flexure named {name!r}" + (f"; did you mean {close}?" if close else "")) from None

    def wrenches(self, data) -> np.ndarray:
        """Wrench of each element on its body B, ``(n, 6)``: ``[moment about site b; force]``, world axes [N m; N]."""
        out = np.empty((len(self), 6))
        self._run(data, k.WRENCH, out6=out)
        return out

    def generalized_forces(self, data) -> np.ndarray:
        """Generalized forces ``(nv,)`` the elements add to ``qfrc_passive`` in this state."""
        out = np.zeros(self.model.nv)
        self._run(data, k.APPLY, qfrc=out)
        return out

    def potential_energies(self, data) -> np.ndarray:
        """Elastic energy of each element, ``(n,)`` [J]."""
        out = np.empty(len(self))
        self._run(data, k.ENERGY, out1=out)
        return out

    def potential_energy(self, data) -> float:
        """Total elastic energy of the elements [J]."""
        return float(self.potential_energies(data).sum())

    def dissipation_powers(self, data) -> np.ndarray:
        """Power dissipated by each element's damping, ``(n,)`` [W] (non-negative)."""
        out = np.empty(len(self))
        self._run(data, k.POWER, out1=out)
        return out

    def dissipation_power(self, data) -> float:
        """Total power dissipated by the elements [W]: the rate at which they remove energy."""
        return float(self.dissipation_powers(data).sum())

    def displacements(self, data) -> np.ndarray:
        """Finite twist ``[tau; t]`` of frame b relative to frame a for each element, ``(n, 6)`` [rad; m]."""
        out = np.empty((len(self), 6))
        self._run(data, k.COORDS, out6=out)
        return out

    # ------------------------------------------------------------------ run-time switches

    def set_enabled(self, name: str, enabled: bool) -> None:
        """Switch element ``name`` on or off (takes effect at the next step)."""
        self._ints[self.index(name), k.ENABLED] = bool(enabled)

    def set_viscous(self, name: str, viscous: bool) -> None:
        """Switch the damping of element ``name`` on or off."""
        i = self.index(name)
        if viscous and self.records[i].B is None:
            raise ValueError(f'flexure {name!r} has no damping matrix B in the model; add "B" to its text record')
        self._ints[i, k.VISCOUS] = bool(viscous)

    def set_method(self, name: str, method: str) -> None:
        """Use ``"twist"`` or ``"dualquat"`` for element ``name``."""
        self._ints[self.index(name), k.METHOD] = validation.method_code(method)

    @property
    def enabled(self) -> np.ndarray:
        return self._ints[:, k.ENABLED].astype(bool)

    @property
    def viscous(self) -> np.ndarray:
        return self._ints[:, k.VISCOUS].astype(bool)

    @property
    def methods(self) -> tuple[str, ...]:
        return tuple("twist" if c == 0 else "dualquat" for c in self._ints[:, k.METHOD])
