"""The models of issue 31's demonstrations of damped stops and rest poses, and what is measured on them.

Used by tests/test_stop_demos.py (which checks the claims) and by scripts/stops_and_preload.py (which records the
figures in docs/results/stops_and_preload.json for docs/background/end_stops.md).

* **A link dropped into a stop** (:func:`link_spec`): a 5 cm, 50 g link on a hinge about y, pulled by gravity and
  held by a soft spring (0.05 N m/rad), released from rest 0.7 rad before its stop at 0.2 rad, MuJoCo's Euler at
  2 ms (a robot file's step). The rigid model has MuJoCo's joint limit with ``solref = (TAU, ZETA)``; the element
  models keep the hinge (the element acts along it only, as a notch hinge in parallel with an ideal one would) and
  have the spring and the stop in an element: the stop conservative (``derived``: 100 K_ii, today's default;
  ``stiff``: as stiff as a stiff notch hinge's derived stop would be, 40 N m/rad) or damped as the limit is
  (``damped``: ``Stops(time_constant=TAU, damping_ratio=ZETA)``, MuJoCo's map of the same ``solref``).
* **A parallel gripper's finger** (:func:`finger_spec`), the four-bar linkage of the public 2F-85 gripper (driver,
  coupler, follower, spring link; the loop closed by a ``connect`` equality; one position actuator on the driver):
  the spring link's spring (``springref`` beyond its travel) presses the coupler against its joint limit, which
  locks it to the driver, so that the follower and its pad translate: the finger closes parallel. The element
  versions replace the joint spring by an element with a rest pose (the same preload), and the coupler's limit by
  an element stop or not at all; without the rest pose (the compiled pose as rest) nothing presses the coupler.
"""

import warnings

import mujoco
import numpy as np

import mjflex

# ------------------------------------------------------------------ the link and its stop

H = 2e-3  # s, MuJoCo's Euler: a robot file's step
LENGTH, MASS, K_HINGE, UPPER, START = 0.05, 0.05, 0.05, 0.2, -0.5  # m, kg, N m/rad, rad, rad
TAU, ZETA = 0.01, 0.25  # the limit's solref, and the damped stop's time constant and damping ratio (TAU >= 2 H)
STIFF = 40.0  # N m/rad: a conservative stop too stiff for the step
#: The element stops of the link, by variant.
LINK_STOPS = {
    "derived": mjflex.Stops(upper=[None, UPPER, None, None, None, None]),
    "stiff": mjflex.Stops(upper=[None, UPPER, None, None, None, None], stiffness=STIFF),
    "damped": mjflex.Stops(upper=[None, UPPER, None, None, None, None], time_constant=TAU, damping_ratio=ZETA),
}


def link_spec(variant):
    """The link on its hinge: ``"rigid"`` (joint spring and limit) or an element variant of ``LINK_STOPS``."""
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.option.timestep = H
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    body = spec.worldbody.add_body(name="link")
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, LENGTH, 0, 0], size=[0.004], mass=MASS)
    joint = body.add_joint(name="hinge", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
    if variant == "rigid":
        joint.stiffness = [K_HINGE, 0, 0]
        joint.range, joint.limited, joint.solref_limit = [-1.5, UPPER], mujoco.mjtLimited.mjLIMITED_TRUE, [TAU, ZETA]
        return spec
    with warnings.catch_warnings():  # the element beside the hinge, on purpose
        warnings.simplefilter("ignore", mjflex.LikelyMistakeWarning)
        mjflex.add_flexure(spec, "notch", "world", "link", pos=[0, 0, 0], K=[1.0, K_HINGE, 1.0, 1e3, 1e3, 1e3],
                           stops=LINK_STOPS[variant])  # fmt: skip
    return spec


def drop(model, T=1.0, nudge=0.0):
    """The link released at ``START + nudge``: its angle after each step ``(n,)`` and its energy (kinetic, gravity,
    springs and stops) ``(n,)`` [J]."""
    flex = mjflex.Flexures(model) if model.nplugin else None
    data = mujoco.MjData(model)
    data.qpos[0] = START + nudge
    q, energy = [], []
    for _ in range(round(T / model.opt.timestep)):
        mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)  # the energy of the state reached
        q.append(data.qpos[0])
        energy.append(data.energy.sum() + (flex.potential_energy(data) if flex else 0.0))
    return np.array(q), np.array(energy)


def rebounds(q, energy, floor):
    """The link's excursions out of its stop after its first contact, deeper than ``floor`` [rad]: their depth
    ``UPPER - min q`` [rad] and the energy at their turning point [J] (at rest: no stop or kinetic energy)."""
    depths, energies, low, touched = [], [], None, False
    for i, x in enumerate(q):
        if x > UPPER:
            if touched and low is not None and UPPER - q[low] > floor:
                depths.append(UPPER - q[low])
                energies.append(energy[low])
            touched, low = True, None
        elif low is None or x < q[low]:
            low = i
    return depths, energies


#: A bounce: an excursion out of the stop that lifts the link's tip by more than 0.1 mm.
BOUNCE = 1e-4 / LENGTH


def link_figures(variant):
    """One variant's figures: its bounces (their depths), the energy lost in each (from one turning point to the
    next, the first being the release), the energy lost in 1 s, the largest angle, and what a nudge of 1e-9 rad of
    the release angle grows to after 1 s."""
    model = link_spec(variant).compile()
    q, energy = drop(model)
    nudged, _ = drop(model, nudge=1e-9)
    depths, turns = rebounds(q, energy, BOUNCE)
    E0 = _released_energy(model)
    losses = -np.diff([E0, *turns])
    return {
        "rebounds_rad": [float(x) for x in depths], "bounce_losses_J": [float(x) for x in losses],
        "energy_lost_J": float(E0 - energy[-1]), "released_energy_J": float(E0),
        "largest_angle_rad": float(np.abs(q).max()), "final_angle_rad": float(q[-1]),
        "nudge_after_1s_rad": float(abs(nudged[-1] - q[-1])),
        "nudge_largest_rad": float(np.abs(nudged - q).max()),
        "stop": _stop_of(model),
    }  # fmt: skip


def _released_energy(model):
    """The energy at the release (at rest): gravity and the springs."""
    data = mujoco.MjData(model)
    data.qpos[0] = START
    mujoco.mj_forward(model, data)
    return data.energy.sum() + (mjflex.Flexures(model).potential_energy(data) if model.nplugin else 0.0)


def _stop_of(model):
    """The element stop's stiffness and damping on ry as the file stores them, and its effective inertia."""
    if not model.nplugin:
        return {"solref": [TAU, ZETA], "inertia_kg_m2": float(1.0 / model.dof_invweight0[0])}
    rec = mjflex.Flexures(model).records[0]
    return {"stiffness": float(rec.stops.stiffness_for(rec.K)[1]), "damping": float(rec.stops.damping_for(6)[1]),
            "omega_h": float(H * np.sqrt(rec.stops.stiffness_for(rec.K)[1] * model.dof_invweight0[0]))}  # fmt: skip


# ------------------------------------------------------------------ the finger


L1, L2, L = 0.025, 0.015, 0.04  # m: driver, coupler (driver + coupler = spring link = L)
BASE = np.array([0.0, 0.015, 0.0])  # m: the spring link's pivot from the driver's
ANGLE0 = np.radians(30)  # the links' angle at qpos0
SPRING_K, SPRINGREF = 3e-3, 1.5  # N m/rad, rad: the spring link's spring, its reference beyond the travel
SWING, CLOSE_T = 0.8, 0.8  # rad, s: the driver's closing command, a ramp over CLOSE_T
FINGER_TAU = 4e-3  # s: solref of the coupler's limit and of the loop's connect (2 steps of 2 ms)
FINE_H, FINE_TAU = 2e-4, 4e-4  # s: the step and time constant at which an element stop holds the preload


def _frame():
    u = np.array([np.cos(ANGLE0), np.sin(ANGLE0), 0.0])
    return u, np.zeros(3), BASE, L1 * u  # direction, driver pivot, spring link pivot, coupler pivot


def finger_spec(variant, h=H, tau=FINGER_TAU):
    """The finger. ``variant``: ``"rigid"`` (joint spring with springref, coupler limit), ``"rest"`` (the spring an
    element with a rest pose; the coupler's limit kept), ``"rest+stop"`` (and the limit an element stop, damped as
    the limit's solref maps) or ``"no rest"`` (the spring an element at the compiled pose; no preload)."""
    u, O1, O2, P1 = _frame()
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.option.timestep = h
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST

    def link(parent, name, pos, end, mass):
        body = parent.add_body(name=name, pos=pos)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=np.r_[np.zeros(3), end], size=[0.003], mass=mass,
                      contype=0, conaffinity=0)  # fmt: skip
        return body

    driver = link(spec.worldbody, "driver", O1, L1 * u, 0.05)
    driver.add_joint(name="drive", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    coupler = link(driver, "coupler", L1 * u, L2 * u, 0.03)
    couple = coupler.add_joint(name="couple", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    spring_link = link(spec.worldbody, "spring_link", O2, L * u, 0.05)
    spring = spring_link.add_joint(name="spring", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    follower = link(spring_link, "follower", L * u, -BASE, 0.05)
    follower.add_joint(name="follow", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    follower.add_site(name="pad", pos=-0.5 * BASE + [-0.005, 0, 0])
    loop = spec.add_equality(type=mujoco.mjtEq.mjEQ_CONNECT, name1="coupler", name2="follower",
                             objtype=mujoco.mjtObj.mjOBJ_BODY)  # fmt: skip
    loop.data[:3] = L2 * u  # the coupler's end, where the follower's pivot is
    loop.solref = [tau, 1.0]
    close = spec.add_actuator(name="close", target="drive", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    close.set_to_position(kp=2.0, kv=0.05)
    if variant != "rest+stop":  # the coupler's joint limit (the spring pushes it to the upper end)
        couple.range, couple.limited = [-0.6, 0.0], mujoco.mjtLimited.mjLIMITED_TRUE
        couple.solref_limit, couple.solimp_limit = [tau, 1.0], [0.95, 0.99, 0.001, 0.5, 2]
    if variant == "rigid":
        spring.stiffness, spring.springref = [SPRING_K, 0, 0], SPRINGREF
        return spec
    rest = ([0.0, 0.0, 0.0], [np.cos(SPRINGREF / 2), 0.0, 0.0, np.sin(SPRINGREF / 2)])  # turned SPRINGREF about z
    with warnings.catch_warnings():  # the elements beside the hinges, on purpose
        warnings.simplefilter("ignore", mjflex.LikelyMistakeWarning)
        mjflex.add_flexure(spec, "spring", "world", "spring_link", pos=O2, K=[1.0, 1.0, SPRING_K, 1e3, 1e3, 1e3],
                           rest=None if variant == "no rest" else rest)  # fmt: skip
        if variant == "rest+stop":
            stop = mjflex.Stops(upper=[None, None, 0.0, None, None, None], time_constant=tau, damping_ratio=1.0)
            mjflex.add_flexure(spec, "couple", "driver", "coupler", pos=P1, K=[0.0] * 6, stops=stop)
    return spec


def close_finger(model):
    """The finger closed by its driver (a ramp to ``SWING`` over ``CLOSE_T``, held until 1 s): the pad's path
    ``(n, 3)`` [m] and its tilt from its orientation at qpos0 ``(n,)`` [rad]."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pad, body = model.site("pad").id, model.body("follower").id
    q0 = data.xquat[body].copy()
    path, tilt = [], []
    h = model.opt.timestep
    for i in range(round(1.0 / h)):
        data.ctrl[0] = SWING * min((i + 1) * h / CLOSE_T, 1.0)
        mujoco.mj_step(model, data)
        path.append(data.site_xpos[pad].copy())
        turn = np.empty(3)
        mujoco.mju_subQuat(turn, data.xquat[body], q0)
        tilt.append(float(np.linalg.norm(turn)))
    return np.array(path), np.array(tilt)


def finger_figures():
    """Per variant: the largest distance of its pad's path from the rigid finger's at the same step [m], the pad's
    largest tilt [rad] and how far it closed [m]; the element stops' stiffness and damping."""
    out = {}
    rigid = {h: close_finger(finger_spec("rigid", h, tau).compile()) for h, tau in ((H, FINGER_TAU),
                                                                                    (FINE_H, FINE_TAU))}  # fmt: skip
    for variant, h, tau in (("rigid", H, FINGER_TAU), ("rest", H, FINGER_TAU), ("no rest", H, FINGER_TAU),
                            ("rest+stop", FINE_H, FINE_TAU), ("rest+stop", H, FINGER_TAU)):  # fmt: skip
        model = finger_spec(variant, h, tau).compile()
        path, tilt = close_finger(model)
        ref = rigid[h][0]
        entry = {"step_s": h, "solref_s": tau, "path_from_rigid_m": float(np.linalg.norm(path - ref, axis=1).max()),
                 "largest_tilt_rad": float(tilt.max()),
                 "closed_m": float(np.linalg.norm(path[-1] - path[0]))}  # fmt: skip
        if variant == "rest+stop":
            rec = mjflex.Flexures(model).records[1]
            entry["stop_stiffness"] = float(rec.stops.stiffness_for(rec.K)[2])
            entry["stop_damping"] = float(rec.stops.damping_for(6)[2])
        out[f"{variant} at {h * 1e3:g} ms"] = entry
    return out


def figures():
    """Everything scripts/stops_and_preload.py records."""
    return {
        "link": {v: link_figures(v) for v in ("rigid", "derived", "stiff", "damped")},
        "finger": finger_figures(),
        "parameters": {
            "step_s": H, "solref": [TAU, ZETA], "stiff_stop": STIFF, "bounce_rad": BOUNCE, "upper_rad": UPPER,
            "release_rad": START,
            "finger_solref_s": FINGER_TAU, "fine_step_s": FINE_H, "fine_solref_s": FINE_TAU,
            "spring": [SPRING_K, SPRINGREF],
        },
    }  # fmt: skip
