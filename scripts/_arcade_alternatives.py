"""The ARCADE scene of compare_alternatives.py (and runs reduce_arcade.py shares): stroke, parasitic motion, modes."""

import os

import mujoco
import numpy as np
from _variants import costs_at_stable_steps, print_costs, simulate, source_case, variant_case

import mjflex
from mjflex.analysis.linearize import normal_modes
from mjflex.app.arcade import rigid_spin_velocity

HERE = os.path.dirname(os.path.abspath(__file__))
ARCADE = os.path.join(HERE, "..", "models", "arcade.xml")
DURATION = 0.04  # s of the paper run: 0.4 period of the guide mode (10.2 Hz, scripts/modes.py)
SMALL_SPEED = 0.01  # m/s: the small-stroke run (no spin, ~80 um), where the guide is nearly linear


def cylinder_probe(m, d):
    """Cylinder relative to the base, base axes: position (3) [m] and tilt of its axis [rad]."""
    b, c = m.body("base").id, m.body("cylinder").id
    R_b = d.xmat[b].reshape(3, 3)
    p = R_b.T @ (d.xpos[c] - d.xpos[b])
    axis = R_b.T @ d.xmat[c].reshape(3, 3)[:, 2]
    return np.concatenate([p, [np.arccos(np.clip(axis[2], -1.0, 1.0))]])


def guide_metrics(x, ref=None):
    """Stroke [mm], parasitic radial offset [um] and tilt [urad]; axial error relative to the reference's stroke."""
    out = {
        "stroke_mm": float(np.abs(x[:, 2]).max() * 1e3),
        "radial_um": float(np.hypot(x[:, 0], x[:, 1]).max() * 1e6),
        "tilt_urad": float(x[:, 3].max() * 1e6),
    }
    if ref is not None:
        n = min(len(x), len(ref))
        out["axial_error"] = float(np.abs(x[:n, 2] - ref[:n, 2]).max() / np.abs(ref[:, 2]).max())
        for key in ("stroke_mm", "radial_um", "tilt_urad"):
            base = guide_metrics(ref)[key]
            out[key.split("_")[0] + "_relative"] = out[key] / base - 1.0 if base else float("nan")
    return out


def small_stroke_state(model):
    d = mujoco.MjData(model)
    rigid_spin_velocity(model, d, 0.0, SMALL_SPEED)
    return d.qpos.copy(), d.qvel.copy()


def modes_of(case, constraints, count=4):
    f, _ = normal_modes(case.model, case.flex, joint_springs=True, constraints=constraints)
    return f[f > 1e-2][:count].tolist()


def arcade_cases(variants):
    """The full model (first) and the variants as cases starting from the paper run; plus the small-stroke states."""
    model = mujoco.MjModel.from_xml_path(ARCADE)
    full = source_case("mjflex twist (full)", model)
    cases = [full] + [variant_case(v, model, full.state) for v in variants]
    small = {}
    for c, v in zip(cases, [None, *variants], strict=True):
        state = small_stroke_state(model)
        if v is None:
            small[c.name] = state
        else:
            d = mujoco.MjData(model)
            d.qpos[:], d.qvel[:] = state
            mujoco.mj_forward(model, d)
            small[c.name] = v.state_from(model, d)
    return cases, small


def run_guide(cases, small, h=1e-5):
    """Guide metrics of every case on the paper run and on the small stroke."""
    results = {}
    ref = simulate(cases[0], h, DURATION, cylinder_probe, every=10)
    ref_small = simulate(cases[0], h, DURATION, cylinder_probe, every=10, state=small[cases[0].name])
    for c in cases:
        x = ref if c is cases[0] else simulate(c, h, DURATION, cylinder_probe, every=10)
        xs = ref_small if c is cases[0] else simulate(c, h, DURATION, cylinder_probe, every=10, state=small[c.name])
        results[c.name] = {
            "paper_run": guide_metrics(x, ref) if x is not None else {"diverged": True},
            "small_stroke": guide_metrics(xs, ref_small) if xs is not None else {"diverged": True},
        }
    return results


def costs_of(cases, repeat, h=1e-5):
    return costs_at_stable_steps(cases, h, repeat, cylinder_probe, 0.005)


def print_guide(results, modes):
    print(f"\n{'model':<24} {'paper run: stroke':>17} {'radial':>9} {'tilt':>9} {'axial err':>9} "
          f"{'| small: stroke':>15} {'axial err':>9}  first modes [Hz]")  # fmt: skip
    for name, r in results.items():
        p, s = r["paper_run"], r["small_stroke"]
        if "diverged" in p:
            print(f"{name:<24} {'diverged':>17}")
            continue
        small = (f"{s['stroke_mm'] * 1e3:>12.1f}um {100 * s.get('axial_error', 0):>8.2f}%"
                 if "diverged" not in s else f"{'diverged':>15}")  # fmt: skip
        first = " ".join(f"{f:.1f}" for f in modes[name])
        print(f"{name:<24} {p['stroke_mm']:>15.3f}mm {p['radial_um']:>7.3f}um {p['tilt_urad']:>7.3f}ur "
              f"{100 * p.get('axial_error', 0):>8.1f}% {small}  {first}")  # fmt: skip


def arcade_scene(repeat):
    variants = [
        mjflex.reduce(ARCADE, 50.0),
        mjflex.reduce(ARCADE, 50.0, scene=("paper_run", DURATION)),
        mjflex.weld_variant(ARCADE),
        mjflex.pseudo_rigid_body_variant(ARCADE),
        mjflex.bushing_variant(ARCADE),
    ]
    variants[1].name = "reduced(50 Hz, paper run)"
    cases, small = arcade_cases(variants)
    modes = {c.name: modes_of(c, c.constraints) for c in cases}
    results = run_guide(cases, small)
    costs = costs_of(cases, repeat)
    print("\n== arcade: the paper run (105 rad/s spin, 5 m/s axial kick, 40 ms) and a 0.01 m/s stroke without spin")
    print_guide(results, modes)
    print_costs(costs, 1e-5)
    verdicts = [_verdict(c.name, results, costs, modes, cases[0].name) for c in cases[1:]]
    return {"results": results, "costs": costs, "modes_hz": modes, "verdicts": verdicts, "duration": DURATION,
            "reports": {v.name: v.report for v in variants}}  # fmt: skip


def _verdict(name, results, costs, modes, full):
    p, s, k, f = results[name]["paper_run"], results[name]["small_stroke"], costs[name], results[full]["paper_run"]
    if "diverged" in p:
        return f"arcade: {name} diverges on the paper run at h = 1e-5 s"
    small = f"{100 * s['axial_error']:.1f} %" if "axial_error" in s else "diverged"
    return (
        f"arcade: {name} runs {k['speedup_at_stable']:.2g}x as fast as mjflex, each at its largest stable RK4 step "
        f"({k['stable_step_s']:.1e} vs {costs[full]['stable_step_s']:.1e} s; {k['ratio_median']:.2f}x the cost per "
        f"step), but on the paper run its stroke is {p['stroke_mm']:.2f} mm (full {f['stroke_mm']:.2f} mm), the "
        f"cylinder's parasitic radial motion {p['radial_um']:.3g} um (full {f['radial_um']:.2g} um) and tilt "
        f"{p['tilt_urad']:.3g} urad (full {f['tilt_urad']:.2g} urad), its axial trajectory off by "
        f"{100 * p['axial_error']:.0f} % of the stroke (0.01 m/s stroke: {small}); first modes "
        f"{', '.join(f'{x:.2f}' for x in modes[name][:2])} Hz (full {', '.join(f'{x:.2f}' for x in modes[full][:2])})"
    )
