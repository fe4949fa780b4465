"""Error bounds of the Warp element forces, derived from float32 rounding (tests/test_warp.py states the derivation).

The reference is the C engine in float64 (:class:`mjflex.Flexures` on a ``mujoco.MjData``). A Warp
result computed from float32 kinematics differs from it by

* input rounding: every kinematic quantity the elements read (``xquat``, ``site_xpos``,
  ``site_xmat``, ``cvel``, ``subtree_com``, ``cdof``) carries errors of a few ``u * |row|`` (``u``
  the unit round-off, ``|row|`` the norm of the 3-, 4- or 6-vector it belongs to). Their effect is
  the sensitivity of the result to each input times that size: :func:`input_sensitivity`
  computes ``S_in = sum_j |q(x + u |row_j| e_j) - q(x - u |row_j| e_j)| / 2`` with the C engine
  (central differences in float64; the result is first order in ``u``), a condition number of
  the element map times ``u`` times the scale of its inputs;
* the element math itself: a chain of about ``N_ARITH`` dependent roundings, each at most ``u`` of
  the magnitudes it combines, ``gamma = N_ARITH u`` (Higham's gamma_n) times :func:`arithmetic_scale`,
  the absolute sums of the terms (``|K| |xi| + |B| |V|`` and the result, times ``(1 + |xi|)^2`` for
  the maps).

End stops (:func:`stop_terms`) add, on each coordinate ``z_i`` with a limit, the magnitudes their
math combines, ``k_i (|z_i| + |limits|)`` (the overshoot is a difference of the two), to the
arithmetic scale, and two terms the first-order sensitivity misses: the energy's second-order
``1/2 k_i dz_i^2`` (``dz`` the bound of the stop coordinates), and, within ``dz_i`` of a limit, the kink
of the force (``k_i dz_i``: the central difference of ``S_in`` sees half of it at best there).
"""

import mujoco
import numpy as np

import mjflex

U32 = 2.0**-24
U64 = 2.0**-53
#: Dependent roundings along the element math: three quaternion products (4 each), the coordinates (~10),
#: the maps (~8), a 6x6 product (6), the rotation to world axes (3), the generalized-force map (~5).
N_ARITH = 48
#: Roundings per level of the kinematic tree in MuJoCo Warp's kinematics (a quaternion product, a
#: rotation and a sum per level), and in the kernels before the inputs meet (two quaternion products
#: and a conjugate product on unit quaternions, 4 roundings each).
N_PER_LEVEL, N_KERNEL_INPUT = 8, 12


def tree_depth(model) -> int:
    """Largest number of bodies between a body and the world (free bodies: 1)."""
    depth = np.zeros(model.nbody, int)
    for b in range(1, model.nbody):
        depth[b] = depth[model.body_parentid[b]] + 1
    return int(depth.max())


def input_factor(model) -> int:
    """How many ``u |row|`` an input of the kernels may be off: MuJoCo Warp's kinematics and the kernels' own."""
    return N_PER_LEVEL * tree_depth(model) + N_KERNEL_INPUT


def c_queries(flex, data) -> dict:
    """The C engine's results on ``data`` as it is."""
    return {
        "wrench": flex.wrenches(data), "energy": flex.potential_energies(data),
        "power": flex.dissipation_powers(data), "twist": flex.displacements(data),
        "qfrc": flex.generalized_forces(data), "stops": flex.stop_coordinates(data),
    }  # fmt: skip


def _rows(data):
    """The inputs the elements read, as (array, row width) pairs: each row's norm sets its perturbation."""
    cvel = data.cvel
    return [(data.xquat, 4), (data.site_xpos, 3), (data.site_xmat, 9), (data.subtree_com, 3), (data.cdof, 3),
            (cvel, 3)]  # fmt: skip


def input_sensitivity(flex, data) -> dict:
    """``S_in`` of every C query: the summed effect of perturbing each input component by ``u32 |row|``."""
    out = {k: np.zeros_like(v, dtype=float) for k, v in c_queries(flex, data).items()}
    for array, width in _rows(data):
        flat = array.reshape(array.shape[0], -1)
        for r in range(flat.shape[0]):
            for c in range(flat.shape[1]):
                block = c // width * width
                h = U32 * np.linalg.norm(flat[r, block : block + width])
                if h == 0.0:
                    continue
                x = flat[r, c]
                flat[r, c] = x + h
                up = c_queries(flex, data)
                flat[r, c] = x - h
                down = c_queries(flex, data)
                flat[r, c] = x
                for k in out:
                    out[k] += 0.5 * np.abs(up[k] - down[k])
    return out


def arithmetic_scale(model, data, flex) -> dict:
    """The magnitudes the element math combines, per query (multiplied by ``gamma`` in the bound)."""
    n = len(flex)
    xi = np.abs(flex.displacements(data))
    W = flex.wrenches(data)
    grow = (1.0 + np.linalg.norm(xi, axis=1)) ** 2
    K = np.abs(flex.element_table.elements["K"][:n].reshape(n, 6, 6))
    B = np.abs(flex.element_table.elements["B"][:n].reshape(n, 6, 6))
    V = np.zeros((n, 6))
    for e, (ba, bb) in enumerate(flex.body_ids):
        ca, cb = data.cvel[ba], data.cvel[bb]
        lever = np.linalg.norm(data.site_xpos[flex.site_ids[e, 1]]) + np.linalg.norm(data.subtree_com[0])
        V[e, :3] = np.abs(ca[:3]) + np.abs(cb[:3])
        V[e, 3:] = np.abs(ca[3:]) + np.abs(cb[3:]) + lever * (V[e, :3].max())
    products = np.einsum("eij,ej->ei", K, xi) + np.einsum("eij,ej->ei", B, V)
    stops = stop_terms(flex, data)
    reach = stops["reach"]  # k_i (|z_i| + |limits|): rotated into world axes, so any component may take all
    products[:, :3] += np.linalg.norm(reach[:, :3], axis=1)[:, None]
    products[:, 3:] += np.linalg.norm(reach[:, 3:], axis=1)[:, None]
    wrench = grow[:, None] * (products + np.abs(W))
    energy = np.einsum("ei,eij,ej->e", xi, K, xi) + np.abs(flex.potential_energies(data))
    energy += np.sum(reach * stops["overshoot"], axis=1)
    power = grow * np.einsum("ei,eij,ej->e", V, B, V)
    twist = xi * (1.0 + np.linalg.norm(xi, axis=1))[:, None] + np.linalg.norm(xi, axis=1)[:, None]
    z = np.abs(stops["z"])
    stop_coords = z * (1.0 + np.linalg.norm(z, axis=1))[:, None] + np.linalg.norm(z, axis=1)[:, None]
    qfrc = _through_jacobians(model, data, flex, wrench)
    return {"wrench": wrench, "energy": energy, "power": power, "twist": twist, "qfrc": qfrc, "stops": stop_coords}


def _through_jacobians(model, data, flex, wrench):
    """``sum_e |J_e|^T |wrench_e|`` over both bodies of each element (at frame b's origin): a bound's qfrc part."""
    qfrc = np.zeros(model.nv)
    jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for e in range(len(flex)):
        point = data.site_xpos[flex.site_ids[e, 1]]
        for body in flex.body_ids[e]:
            mujoco.mj_jac(model, data, jp, jr, point, int(body))
            qfrc += np.abs(jp).T @ wrench[e, 3:] + np.abs(jr).T @ wrench[e, :3]
    return qfrc


def stop_terms(flex, data) -> dict:
    """The end stops' quantities the bounds need, ``(n, 6)`` each: the stop coordinates ``z``, their stiffness
    ``k`` (0 without a limit), ``reach`` = ``k (|z| + |finite limits|)`` and the ``overshoot`` beyond a limit."""
    n = len(flex)
    el = flex.element_table.elements[:n]
    z = flex.stop_coordinates(data)
    lo, hi, k = el["stop_lo"], el["stop_hi"], el["stop_k"] * el["stops"][:, None]
    limits = np.where(np.isfinite(lo), np.abs(lo), 0.0) + np.where(np.isfinite(hi), np.abs(hi), 0.0)
    over = np.maximum(z - hi, 0.0) + np.maximum(lo - z, 0.0)
    return {"z": z, "k": k, "reach": k * (np.abs(z) + limits), "overshoot": over, "lo": lo, "hi": hi}


def bounds(model, data, flex, unit_arith=U32) -> dict:
    """The derived bound of every query: ``input_factor * S_in + N_ARITH * unit_arith * S_arith``."""
    s_in = input_sensitivity(flex, data)
    s_ar = arithmetic_scale(model, data, flex)
    c = input_factor(model)
    out = {k: c * s_in[k] + N_ARITH * unit_arith * s_ar[k] for k in s_in}
    # the energy is quadratic: at (near) zero displacement its first-order sensitivity vanishes, and the
    # second-order term 1/2 dxi^T K dxi of the displacement's own error remains
    n = len(flex)
    K = np.abs(flex.element_table.elements["K"][:n].reshape(n, 6, 6))
    out["energy"] += 0.5 * np.einsum("ei,eij,ej->e", out["twist"], K, out["twist"])
    # the end stops: the same second-order term of the energy, and the kink of the force within dz of a limit
    stops, dz = stop_terms(flex, data), out["stops"]
    out["energy"] += 0.5 * np.sum(stops["k"] * dz * dz, axis=1)
    z, lo, hi = stops["z"], stops["lo"], stops["hi"]
    kink = stops["k"] * dz * ((np.abs(z - lo) <= dz) | (np.abs(z - hi) <= dz))
    grow = (1.0 + np.linalg.norm(np.abs(flex.displacements(data)), axis=1)) ** 2
    for part in (slice(0, 3), slice(3, 6)):
        out["wrench"][:, part] += (grow * np.linalg.norm(kink[:, part], axis=1))[:, None]
    if kink.any():  # the generalized forces: the kink's wrench through the bodies' Jacobians (rarely non-zero)
        out["qfrc"] += _through_jacobians(model, data, flex, grow[:, None] * np.linalg.norm(
            kink.reshape(-1, 2, 3), axis=2).repeat(3, axis=1))  # fmt: skip
    return out


#: Roundings per RK4 step of MuJoCo Warp that act like relative perturbations of the state: the stored qpos
#: and qvel (2), and in each of the 4 stages the kinematics and the forces (8).
N_STEP_ROUNDINGS = 10


def state_groups(model):
    """Index groups of ``[qpos; qvel]`` compared together: per joint its positions, rotation, velocities."""
    groups, nq = [], model.nq
    for j in range(model.njnt):
        q, v, kind = int(model.jnt_qposadr[j]), nq + int(model.jnt_dofadr[j]), int(model.jnt_type[j])
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            groups += [range(q, q + 3), range(q + 3, q + 7), range(v, v + 3), range(v + 3, v + 6)]
        elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
            groups += [range(q, q + 4), range(v, v + 3)]
        else:
            groups += [range(q, q + 1), range(v, v + 1)]
    return [list(g) for g in groups]


def perturbation_scales(model, data):
    """The size of one rounding of each ``[qpos; qvel]`` component: MuJoCo Warp computes positions, kinematics and
    forces from coordinates of the size of the model (``L``, the largest body or site distance from the origin), so
    positions are off by ``u L`` (not ``u |x|``: a body at the origin has forces from its neighbours' positions),
    rotations by ``u``, velocities by ``u`` times their joint's velocity norm."""
    L = max(np.linalg.norm(data.xpos, axis=1).max(), np.linalg.norm(data.site_xpos, axis=1).max(initial=0.0))
    qs, vs = np.full(model.nq, L), np.zeros(model.nv)
    for j in range(model.njnt):
        q, v, kind = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_type[j])
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            qs[q + 3 : q + 7] = 1.0
            for a in (v, v + 3):
                vs[a : a + 3] = np.linalg.norm(data.qvel[a : a + 3])
        elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
            qs[q : q + 4], vs[v : v + 3] = 1.0, np.linalg.norm(data.qvel[v : v + 3])
        else:
            qs[q] = 1.0 if kind == int(mujoco.mjtJoint.mjJNT_HINGE) else L
            vs[v] = abs(data.qvel[v])
    return qs, vs


def c_trajectory(model, qpos, qvel, nstep, *, perturb=0.0, seed=0):
    """``[qpos; qvel]`` after each of ``nstep`` C-engine steps from (qpos, qvel) rounded to float32; with
    ``perturb``, every component is moved by ``+- perturb u32`` times its :func:`perturbation_scales` (random
    signs) before each step."""
    rng = np.random.default_rng(seed)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = np.float32(qpos), np.float32(qvel)
    out = np.empty((nstep, model.nq + model.nv))
    with mjflex.Flexures(model):  # text records need the provider; plugin elements are the model's own
        _steps(model, data, out, perturb, rng)
    return out


def _steps(model, data, out, perturb, rng):
    for k in range(len(out)):
        if perturb:  # before the step: its kinematics and forces see the perturbed state
            mujoco.mj_kinematics(model, data)
            qs, vs = perturbation_scales(model, data)
            data.qpos[:] += perturb * U32 * qs * rng.choice([-1.0, 1.0], model.nq)
            data.qvel[:] += perturb * U32 * vs * rng.choice([-1.0, 1.0], model.nv)
        mujoco.mj_step(model, data)
        out[k] = np.concatenate([data.qpos, data.qvel])


def trajectory_bound(model, qpos, qvel, nstep, seeds=4):
    """``(reference, bound)``: the C trajectory and, per step and state group, the largest deviation of
    ``seeds`` runs perturbed by ``N_STEP_ROUNDINGS u32`` per step (see tests/test_warp.py)."""
    ref = c_trajectory(model, qpos, qvel, nstep)
    groups = state_groups(model)
    bound = np.zeros((nstep, len(groups)))
    for seed in range(seeds):
        dev = np.abs(c_trajectory(model, qpos, qvel, nstep, perturb=N_STEP_ROUNDINGS, seed=seed) - ref)
        bound = np.maximum(bound, np.stack([dev[:, g].max(1) for g in groups], 1))
    return ref, bound


def observation_bounds(model, flex, qpos, qvel, steps, observe):
    """Per observed name, the bound of ``observe`` at each step count in ``steps`` (after that many C steps from
    (qpos, qvel)): the observation's sensitivity to the state, each component moved by its trajectory bound
    (:func:`trajectory_bound`, per joint group), summed (central differences, first order)."""
    ref, bound = trajectory_bound(model, qpos, qvel, max(steps))
    groups = state_groups(model)
    out = []
    data = mujoco.MjData(model)
    nq = model.nq

    def seen(x):
        data.qpos[:], data.qvel[:] = x[:nq], x[nq:]
        mujoco.mj_forward(model, data)
        values = observe(model, flex, data).items()
        return {k: np.asarray(v[1] if isinstance(v, tuple) else v, float) for k, v in values}

    for k in steps:
        b = np.zeros(ref.shape[1])
        for g, idx in enumerate(groups):
            b[idx] = bound[k - 1, g]
        total = {name: np.zeros_like(v) for name, v in seen(ref[k - 1]).items()}
        for j in np.flatnonzero(b):
            x = ref[k - 1].copy()
            x[j] += b[j]
            up = seen(x)
            x[j] -= 2 * b[j]
            down = seen(x)
            for name in total:
                total[name] += 0.5 * np.abs(up[name] - down[name])
        out.append(total)
    return out
