"""mjflex against MuJoCo's native ways of modelling flexures, on three scenes, each ending in a verdict.

Usage::

    python scripts/compare_alternatives.py [--scenes bushing cantilever arcade] [--json out/compare_alternatives.json]
                                     [--repeat 11] [--runs 1]

``--runs N`` repeats everything in N fresh processes and pools the timing repeats (scripts/_bench.py).

Scenes (``mjflex.app.scenes`` and ``models/arcade.xml``) and what each measures:

* **bushing**: a 1.2 kg block on a coupled 6x6 bushing, launched into a rotation beyond 1 rad
  and translations of centimetres, and loaded statically by a combined wrench. Reference: the
  bushing law itself (mjflex twist: ``K`` on the finite twist). Measured: pose error over
  0.2 s, static pose error, first frequencies.
* **cantilever**: a 10 cm aluminium beam (2 x 10 mm) clamped at one end, as a chain of 10
  elements, against beam theory: tip deflection under a small end load (Timoshenko), under a
  large one (the elastica, solved with scipy), and the first bending frequency (Euler-
  Bernoulli) from a release.
* **arcade**: the ARCADE guide's paper run (1000 rpm spin and 5 m/s of the cylinder, 40 ms)
  and a small stroke (0.01 m/s, no spin): stroke, parasitic motion of the cylinder (radial
  offset and tilt of its axis relative to the base), axial trajectory error against the full
  model, first frequencies.

MuJoCo-native alternatives (``mjflex.variants.alternatives``): matched soft welds, the pseudo-rigid-body model
(one joint spring per element, loops closed by ``connect`` constraints, closing springs on
fixed tendons), the 6-joint bushing, MuJoCo 4.0's 1-D flexcomp rod (cantilever only), and
``mjflex.reduce``. Costs: median wall time of one step (interleaved repeats, ratio to mjflex
twist in the same repeat), at the scene's step and at each model's own largest stable step
(RK4, doubling then bisection, divergence = MuJoCo's bad-acceleration warning or a blow-up).
Machines are shared and noisy: read the ratios, not the absolute times.
"""

import argparse

import mujoco
import numpy as np
import scipy.integrate
from _bench import add_runs_option, measured_in_processes, write_json
from _variants import (
    Case,
    add_speedups,
    costs_at_stable_steps,
    print_costs,
    rotation_angle,
    simulate,
    source_case,
    variant_case,
)

import mjflex
from mjflex.analysis.linearize import normal_modes
from mjflex.app.scenes import Beam, bushing_spec, cantilever_flexcomp_spec, cantilever_spec


def _modes(case, count=4):
    if case.name == "flexcomp":
        return []  # the rod's elasticity is not in qfrc_spring: its frequency comes from the release below
    f, _ = normal_modes(case.model, case.flex, joint_springs=True, constraints=case.constraints)
    return f[f > 1e-2][:count].tolist()


# ------------------------------------------------------------------------------------------ bushing


def _block(m, d):
    i = m.body("block").id
    return np.concatenate([d.xpos[i], d.xmat[i]])


def _pose_errors(x, ref):
    dp = np.linalg.norm(x[:, :3] - ref[:, :3], axis=1).max()
    da = max(rotation_angle(a[3:].reshape(3, 3).T @ b[3:].reshape(3, 3)) for a, b in zip(x, ref, strict=True))
    return float(dp), float(da)


def bushing_scene(repeat):
    spec = bushing_spec()
    model = spec.compile()
    src = source_case("mjflex twist", model)
    dq_spec = mjflex.copy_spec(spec)
    mjflex.edit_elements(dq_spec, method="dualquat")  # a plugin element's method is part of the model
    dq = source_case("mjflex dualquat", dq_spec.compile())
    cases = [src, dq] + [variant_case(v, model, src.state) for v in (
        mjflex.bushing_variant(spec), mjflex.weld_variant(spec), mjflex.weld_variant(spec, match="mean"),
        mjflex.pseudo_rigid_body_variant(spec))]  # fmt: skip
    h, T = model.opt.timestep, 0.2
    wrench = np.array([600.0, -400.0, 900.0, 12.0, -8.0, 15.0])  # [force; torque] at the block's centre, world

    def load(m, d):
        d.xfrc_applied[m.body("block").id] = wrench

    rest = (model.qpos0.copy(), np.zeros(model.nv))
    results = {}
    ref = simulate(src, h, T, _block, every=10)
    ref_static = simulate(src, h, 1.0, _block, every=1000, load=load, damping=0.999, state=rest)[-1:]
    for c in cases:
        x = ref if c is src else simulate(c, h, T, _block, every=10)
        state0 = (c.model.qpos0.copy(), np.zeros(c.model.nv))
        xs = simulate(c, h, 1.0, _block, every=1000, load=load, damping=0.999, state=state0)
        r = {"modes_hz": _modes(c, 6)}
        if x is not None:
            r["dynamic_position_error_mm"], r["dynamic_rotation_error_deg"] = _pose_errors(x, ref)
            r["dynamic_position_error_mm"] *= 1e3
            r["dynamic_rotation_error_deg"] = np.degrees(r["dynamic_rotation_error_deg"])
            r["peak_rotation_deg"] = float(np.degrees(max(rotation_angle(p[3:].reshape(3, 3)) for p in x)))
        if xs is not None:
            dp, da = _pose_errors(xs[-1:], ref_static)
            r["static_position_error_mm"], r["static_rotation_error_deg"] = dp * 1e3, float(np.degrees(da))
            r["static_rotation_deg"] = float(np.degrees(rotation_angle(xs[-1, 3:].reshape(3, 3))))
            r["static_displacement_mm"] = float(np.linalg.norm(xs[-1, :3]) * 1e3)
        results[c.name] = r
    costs = costs_at_stable_steps(cases, h, repeat, _block, 0.01)
    print("\n== bushing: 1.2 kg block on a coupled bushing; reference = the 6x6 law on the finite twist (mjflex twist)")
    print(f"{'model':<24} {'peak rot':>9} {'dyn err':>16} {'static':>16} {'first modes [Hz]':>30}")
    for name, r in results.items():
        g = lambda key, r=r: r.get(key, np.nan)  # noqa: E731
        dyn = f"{g('dynamic_position_error_mm'):6.2f}mm {g('dynamic_rotation_error_deg'):5.1f}deg"
        sta = f"{g('static_position_error_mm'):6.2f}mm {g('static_rotation_error_deg'):5.1f}deg"
        modes = " ".join(f"{f:.1f}" for f in r["modes_hz"][:6])
        print(f"{name:<24} {r.get('peak_rotation_deg', np.nan):>8.0f}d {dyn:>16} {sta:>16} {modes:>30}")
    print_costs(costs, h)
    verdicts = _bushing_verdicts(results, costs)
    return {"results": results, "costs": costs, "verdicts": verdicts, "timestep": h, "duration": T,
            "static_wrench": wrench.tolist()}  # fmt: skip


def _bushing_verdicts(results, costs):
    out = []
    for name in results:
        if name.startswith("mjflex twist"):
            continue
        c = costs[name]
        g = lambda key, r=results[name]: r.get(key, np.nan)  # noqa: E731
        out.append(f"bushing: {name} costs {c['ratio_median']:.2f}x mjflex twist per step (stable to "
                   f"{c['stable_step_s']:.1e} s) and misses the 6x6 law by {g('dynamic_rotation_error_deg'):.1f} deg / "
                   f"{g('dynamic_position_error_mm'):.1f} mm in motion (peak rotation {g('peak_rotation_deg'):.0f} "
                   "deg), "
                   f"{g('static_rotation_error_deg'):.1f} deg / {g('static_position_error_mm'):.2f} mm at rest under "
                   "load")  # fmt: skip
    return out


# ------------------------------------------------------------------------------------------ cantilever


def elastica_tip(beam, F):
    """Tip position (x, y) [m] of an inextensible Euler-Bernoulli cantilever under a dead end load F along y."""
    a = F / beam.EI

    def rhs(s, y):  # y = (theta, kappa, x, y)
        return np.vstack([y[1], -a * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    s = np.linspace(0.0, beam.L, 201)
    guess = np.zeros((4, s.size))
    guess[2] = s
    sol = scipy.integrate.solve_bvp(rhs, bc, s, guess, tol=1e-10, max_nodes=100000)
    if not sol.success:
        raise RuntimeError(f"elastica did not converge: {sol.message}")
    return sol.y[2, -1], sol.y[3, -1]


def _tip_probe(name):
    def probe(m, d):
        if name == "flexcomp":
            return d.xpos[m.body("rod_11").id].copy()
        return d.site_xpos[m.site("tip").id].copy()

    return probe


def _tip_load(name, F):
    def load(m, d):
        d.qfrc_applied[:] = 0.0
        if name == "flexcomp":
            d.xfrc_applied[m.body("rod_11").id, 1] = F
        else:
            mujoco.mj_applyFT(m, d, np.array([0.0, F, 0.0]), np.zeros(3), d.site_xpos[m.site("tip").id],
                              m.site_bodyid[m.site("tip").id], d.qfrc_applied)  # fmt: skip

    return load


def _crossing_frequency(y, dt):
    s = np.sign(y - y.mean())
    c = np.nonzero(s[1:] != s[:-1])[0]
    return (len(c) - 1) / 2.0 / ((c[-1] - c[0]) * dt) if len(c) > 2 else float("nan")


def cantilever_scene(repeat, n=10):
    beam = Beam()
    spec = cantilever_spec(beam, n, tip_speed=0.1)  # the kick is the initial state of the stable-step search
    model = spec.compile()
    src = source_case("mjflex twist", model)
    cases = [src] + [variant_case(v, model, src.state) for v in (
        mjflex.bushing_variant(spec), mjflex.weld_variant(spec), mjflex.pseudo_rigid_body_variant(spec),
        mjflex.reduce(spec, 2000.0))]  # fmt: skip
    fc_model = cantilever_flexcomp_spec(beam, n).compile()
    kicked = np.zeros(fc_model.nv)
    kicked[fc_model.jnt_dofadr[fc_model.body(f"rod_{n + 1}").jntadr[0]] + 1] = 0.1
    cases.append(Case("flexcomp", fc_model, None, (fc_model.qpos0.copy(), kicked)))
    h = model.opt.timestep
    small, large = 0.1, 0.9 * beam.EI / beam.L**2 * 3  # large: linear theory would give 0.9 L
    x_el, y_el = elastica_tip(beam, large)
    f1 = beam.frequencies(1)[0]
    results = {}
    for c in cases:
        key = "flexcomp" if c.name == "flexcomp" else "chain"
        rest = (c.model.qpos0.copy(), np.zeros(c.model.nv))
        probe = _tip_probe(key)
        tip0 = simulate(c, h, h, probe, state=rest)[0]
        r = {}
        for label, F, steps in (("small", small, 0.1), ("large", large, 0.1)):
            x = simulate(c, h, steps, probe, every=round(steps / h), load=_tip_load(key, F), damping=0.998, state=rest)
            if x is not None:
                r[f"{label}_tip"] = (x[-1] - tip0).tolist()
                if label == "small":
                    released = c.last
        r["small_error"] = r["small_tip"][1] / beam.tip_deflection(small) - 1.0 if "small_tip" in r else np.nan
        if "large_tip" in r:
            dx, dy = r["large_tip"][0], r["large_tip"][1]
            r["large_error"] = float(np.hypot(dx - (x_el - beam.L), dy - y_el) / np.hypot(x_el - beam.L, y_el))
        y = simulate(c, h, 0.06, lambda m, d, p=probe: p(m, d)[1], state=(released[0], np.zeros(c.model.nv)))
        r["f1_hz"] = _crossing_frequency(y, h) if y is not None else np.nan
        r["f1_error"] = r["f1_hz"] / f1 - 1.0
        results[c.name] = r
    costs = costs_at_stable_steps(cases, h, repeat, lambda m, d: d.qpos.copy(), 0.002)
    print(f"\n== cantilever: L {beam.L} m, t {beam.t} m, b {beam.b} m, aluminium, {n} segments; beam theory: tip "
          f"{beam.tip_deflection(small) * 1e6:.2f} um under {small} N, elastica tip ({x_el:.4f}, {y_el:.4f}) m under "
          f"{large:.1f} N, f1 {f1:.1f} Hz")  # fmt: skip
    print(f"{'model':<24} {'small load':>11} {'large load':>11} {'f1 [Hz]':>9} {'f1 err':>8}")
    for name, r in results.items():
        print(f"{name:<24} {100 * r['small_error']:>10.2f}% {100 * r.get('large_error', np.nan):>10.2f}% "
              f"{r['f1_hz']:>9.1f} {100 * r['f1_error']:>7.2f}%")  # fmt: skip
    print_costs(costs, h)
    verdicts = [
        f"cantilever: {name} costs {costs[name]['ratio_median']:.2f}x mjflex per step (stable to "
        f"{costs[name]['stable_step_s']:.1e} s, {costs[name]['speedup_at_stable']:.2f}x mjflex's speed at each one's "
        f"stable step); tip deflection off beam theory by {100 * r['small_error']:.1f} % (small load), elastica by "
        f"{100 * r.get('large_error', np.nan):.1f} % (large), f1 by {100 * r['f1_error']:.1f} %"
        for name, r in results.items()
    ]
    return {"results": results, "costs": costs, "verdicts": verdicts, "beam": beam.__dict__, "segments": n,
            "loads_N": [small, large], "elastica_tip": [x_el, y_el], "f1_euler_bernoulli_hz": f1}  # fmt: skip


def main():
    from _arcade_alternatives import arcade_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bushing", "cantilever", "arcade"])
    ap.add_argument("--repeat", type=int, default=11, help="interleaved repeats per process (default 11)")
    ap.add_argument("--json", default="out/compare_alternatives.json")
    add_runs_option(ap)
    args = ap.parse_args()
    scenes = {"bushing": bushing_scene, "cantilever": cantilever_scene, "arcade": arcade_scene}
    out = measured_in_processes(args)
    if out is None:
        out = {name: scenes[name](args.repeat) for name in args.scenes}
    else:  # pooled: speed-ups from the pooled ratios; the verdicts' text is the first run's
        for name in args.scenes:
            add_speedups(out[name]["costs"], next(iter(out[name]["costs"])))
    print("\nverdicts:")
    for name in args.scenes:
        for line in out[name]["verdicts"]:
            print(" -", line)
    write_json(args.json, out)


if __name__ == "__main__":
    main()
