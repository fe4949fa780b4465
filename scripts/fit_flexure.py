"""Fit quadratic and higher-order potentials of a leaf spring bent far beyond its linear range.

Usage::

    python scripts/fit_flexure.py [--slenderness 10 25 100] [--train 150] [--weights compliance]
                                  [--out out/fit_flexure]

Reference ("measured") data: a clamped leaf spring of length L = 40 mm and thickness t = L / s
(s = the slenderness) as a chain of 40 short mjflex twist elements
(:class:`mjflex.geometry.rod.LeafChain`, a discrete geometrically exact rod), solved statically under
random tip loads in the plane of bending that rotate the tip by up to ~100 degrees. One element
between the clamp and the tip body, frames at the leaf's centre, is fitted to those (pose, wrench)
samples with :func:`mjflex.fit_potential`: orders N = 2, 4, 6 in twist and dual-quaternion
coordinates, restricted to the plane (``variables=(2, 3, 4)``) and to terms that respect the leaf's
mirror symmetry (``symmetries=[(1, -1, 1)]``), compliance-weighted by the beam
stiffness (``--weights compliance``) or with the default RMS weights (``--weights rms``). The linear
beam stiffness of :func:`mjflex.geometry.leaf_spring_stiffness` is the unfitted baseline, and
"beam K + N" keeps it as the stiffness at rest and fits only the terms (``K=`` of ``fit_potential``).

Held-out load sweeps (transverse force, pure moment, force with axial tension, force with axial
compression): each single-element model is solved for its stable equilibrium under the same load
(Newton on the total potential from rest, load ramped) and its tip position compared with the
chain's. A model without a stable equilibrium there counts as a failure, never as a result. In
dimensionless loads (moment L/EI, force L^2/EI) the results depend only on s and Poisson's ratio.

Prints a table per slenderness (worst tip-position error in % of L per range of tip rotation,
failures) and writes ``fit_flexure.json`` (all numbers, the fitted potentials) and
``fit_flexure.png`` (error against tip rotation) to ``--out``.
"""

import argparse
import os
import time
import warnings

import numpy as np
from _bench import write_json

import mjflex
from mjflex.geometry import leaf_spring_stiffness
from mjflex.geometry.rod import LeafChain

L, WIDTH, E, NU = 0.040, 0.008, 200e9, 0.3  # [m, m, Pa]; t = L / slenderness
PLANE = (2, 3, 4)  # [theta_z; x; y] within [rotation; translation]
MIRROR = [(1, -1, 1)]  # the leaf is symmetric about its x-z plane (y -> -y)
ORDERS = (2, 4, 6)
FIXED_K_ORDERS = (4, 6)  # terms fitted on top of the beam stiffness (fit_potential(..., K=K_beam))
BINS_DEG = (15, 45, 80)
SWEEPS = {  # dimensionless tip loads (M L/EI, Fx L^2/EI, Fy L^2/EI) along s in (0, 1]
    "transverse force": lambda s: (0.0, 0.0, 2.6 * s),
    "pure moment": lambda s: (1.3 * s, 0.0, 0.0),
    "force with tension": lambda s: (0.0, 1.5, 2.6 * s),
    "force with compression": lambda s: (0.2 * s, -0.5, 2.0 * s),
}


def _rot_z(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _frame_b(tip):
    """Frame b (on the tip body, at the leaf's centre at rest) of a tip pose (theta, x, y)."""
    R = _rot_z(tip[0])
    return R, np.array([tip[1], tip[2], 0.0]) - R @ np.array([L / 2, 0.0, 0.0])


def element_sample(tip, load):
    """Pose of b in a (frame a: the clamp at the leaf's centre) and the element's wrench on the tip body.

    The wrench is in a axes about b's origin: in equilibrium it balances the tip load.
    """
    R, p_b = _frame_b(tip)
    F = np.array([load[1], load[2], 0.0])
    moment = load[0] + np.cross(np.array([tip[1], tip[2], 0.0]) - p_b, F)[2]
    return R, p_b - np.array([L / 2, 0.0, 0.0]), -np.array([0.0, 0.0, moment, F[0], F[1], 0.0])


class SingleElement:
    """The tip body on one fitted element: generalized forces and total potential in (theta, x, y)."""

    P_A = np.array([L / 2, 0.0, 0.0])

    def __init__(self, K, method, terms):
        self.K, self.method, self.terms = K, method, terms

    def force(self, u, load):
        """``[moment about the tip; fx; fy]`` on the tip body: element plus load."""
        R, p_b = _frame_b(u)
        W = mjflex.wrench_on_b(np.eye(3), self.P_A, R, p_b, self.K, method=self.method, terms=self.terms, check=False)
        m = W[2] + np.cross(p_b - np.array([u[1], u[2], 0.0]), W[3:])[2]
        return np.array([m, W[3], W[4]]) + load

    def energy(self, u, load):
        R, p_b = _frame_b(u)
        U = mjflex.potential(np.eye(3), self.P_A, R, p_b, self.K, method=self.method, terms=self.terms, check=False)
        return float(U) - load @ u

    def hessian(self, u, load):
        h = np.array([1e-6, 1e-6 * L, 1e-6 * L])
        H = np.stack([(self.force(u - hi, load) - self.force(u + hi, load)) / (2 * hi[i]) for i, hi in
                      enumerate(np.diag(h))], axis=1)  # fmt: skip
        return 0.5 * (H + H.T)

    def equilibrium(self, load, scale, steps=8, max_iter=60):
        """Stable equilibrium under ``load`` reached from rest, or None (none found, or unstable)."""
        u = np.array([0.0, L, 0.0])
        for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
            f = lam * np.asarray(load)
            for _ in range(max_iter):
                G = self.force(u, f)
                if np.abs(G / scale).max() < 1e-9:
                    break
                H = self.hessian(u, f)
                d = np.sqrt(np.abs(np.diag(H)))
                if not (np.all(np.isfinite(H)) and np.all(d > 0) and np.all(np.isfinite(G))):
                    return None  # the model's energy is not finite or flat here: no equilibrium
                lam_min = np.linalg.eigvalsh(H / np.outer(d, d))[0]
                if lam_min <= 1e-8:  # not convex here: shift to a descent direction
                    H = H + (1e-8 - lam_min + 1e-3) * np.diag(d * d)
                u = self._line_search(u, np.linalg.solve(H, G), f)
            else:
                return None
        d = np.sqrt(np.abs(np.diag(self.hessian(u, load))))
        stable = np.linalg.eigvalsh(self.hessian(u, load) / np.outer(d, d))[0] > 0
        return u if stable else None

    def _line_search(self, u, du, load):
        e0, step = self.energy(u, load), 1.0
        for _ in range(40):
            if self.energy(u + step * du, load) <= e0 + 1e-13 * abs(e0):
                break
            step *= 0.5
        return u + step * du


def training_loads(rng, n, scale):
    """Random tip loads: rotation-driving part in a disk (tip rotation up to ~100 deg), axial part in a band."""
    r = 1.6 * np.sqrt(rng.uniform(0, 1, n))
    phi = rng.uniform(0, 2 * np.pi, n)
    fx = rng.uniform(-0.8, 2.5, n)
    small = rng.uniform(-0.05, 0.05, (n // 8, 3))  # near rest: pins the stiffness at rest
    return np.vstack([np.stack([r * np.cos(phi), fx, 2.0 * r * np.sin(phi)], axis=1), small]) * scale


def solve_chain(chain, loads):
    tips = []
    for load in loads:
        try:
            q = chain.solve(load)
        except RuntimeError:
            q = chain.solve(load, steps=16)
        tips.append(q[-1].copy())
    return np.array(tips)


def fit_models(R, p, W, K_beam, weighting):
    weights = np.linalg.inv(np.linalg.cholesky(K_beam)) if weighting == "compliance" else None
    out = {}
    for method in ("twist", "dualquat"):
        out[(method, "beam theory")] = (K_beam, None, None)
        for N in ORDERS:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", mjflex.FitWarning)
                fit = mjflex.fit_potential(R, p, W, method=method, order=N, variables=PLANE, wrench_frame="a",
                                           weights=weights, symmetries=MIRROR)  # fmt: skip
            for w in caught:
                print(f"  {method} N = {N}: {w.message}")
            out[(method, f"N = {N}")] = (fit.K, fit.terms, fit)
        for N in FIXED_K_ORDERS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", mjflex.FitWarning)
                fit = mjflex.fit_potential(R, p, W, method=method, order=N, variables=PLANE, wrench_frame="a",
                                           weights=weights, K=K_beam, symmetries=MIRROR)  # fmt: skip
            out[(method, f"beam K + N = {N}")] = (fit.K, fit.terms, fit)
    return out


def study(slenderness, args, rng):
    """Samples, fits and held-out errors for one leaf; returns (table rows, points, potentials)."""
    t0 = time.perf_counter()
    T = L / slenderness
    chain = LeafChain(L, T, WIDTH, E, NU, n=args.segments)
    EI = chain.EI
    scale = np.array([EI / L, EI / L**2, EI / L**2])
    loads = training_loads(rng, args.train, scale)
    tips = solve_chain(chain, loads)
    R, p, W = (np.array(a) for a in zip(*(element_sample(t, f) for t, f in zip(tips, loads, strict=True)),
                                        strict=True))  # fmt: skip
    tests = []
    for case, path in SWEEPS.items():
        sweep = np.array([path(s) for s in np.linspace(0, 1, args.sweep_points + 1)[1:]]) * scale
        tests += [(case, tip, load) for load, tip in zip(sweep, solve_chain(chain, sweep), strict=True)]
    reach = max(abs(np.degrees(t[1][0])) for t in tests)
    print(f"\nL/t = {slenderness:g}: {len(loads)} training samples (tip rotation up to "
          f"{np.degrees(np.abs(tips[:, 0]).max()):.0f} deg), {len(tests)} held-out loads (up to {reach:.0f} deg); "
          f"chain solved in {time.perf_counter() - t0:.0f} s")  # fmt: skip
    K_beam = leaf_spring_stiffness(L, T, WIDTH, E, NU, method="beam")
    models = fit_models(R, p, W, K_beam, args.weights)
    table, points = [], {}
    for (method, name), (K, terms, fit) in models.items():
        element = SingleElement(K, method, terms)
        rows = []
        for case, tip, load in tests:
            u = element.equilibrium(load, scale)
            err = None if u is None else float(100 * np.linalg.norm(u[1:] - tip[1:]) / L)
            rows.append({"case": case, "tip_rotation_deg": float(np.degrees(tip[0])), "tip_error_pct_L": err})
        entry = {"slenderness": slenderness, "method": method, "model": name,
                 "parameters": None if fit is None else len(fit.parameters),
                 "relative_residual": None if fit is None else fit.relative_residual,
                 "condition": None if fit is None else fit.condition,
                 "failures": sum(r["tip_error_pct_L"] is None for r in rows)}  # fmt: skip
        for limit in BINS_DEG:
            vals = [r["tip_error_pct_L"] for r in rows if abs(r["tip_rotation_deg"]) <= limit]
            entry[f"worst_tip_error_pct_L_upto_{limit}deg"] = max((v for v in vals if v is not None), default=None)
            entry[f"failures_upto_{limit}deg"] = sum(v is None for v in vals)
        table.append(entry)
        points[f"{method} {name}"] = rows
    potentials = {f"{m} {n}": {"K": K.tolist(), "terms": None if t is None else t.to_dict()}
                  for (m, n), (K, t, _) in models.items()}  # fmt: skip
    return table, points, potentials


def print_table(table):
    head = "  ".join(f"<= {b} deg" for b in BINS_DEG)
    print(f"{'L/t':>4} {'method':<9} {'model':<12} {'params':>6} {'resid':>6} {'cond':>8}   worst tip error [% L] "
          f"(failures) for |rotation| {head}")  # fmt: skip
    for e in table:
        cells = []
        for b in BINS_DEG:
            worst, fails = e[f"worst_tip_error_pct_L_upto_{b}deg"], e[f"failures_upto_{b}deg"]
            cells.append(f"{'-' if worst is None else f'{worst:.3g}':>7}{f' ({fails})' if fails else '    '}")
        par = "-" if e["parameters"] is None else str(e["parameters"])
        res = "-" if e["relative_residual"] is None else f"{e['relative_residual']:.2g}"
        cond = "-" if e["condition"] is None else f"{e['condition']:.2g}"
        print(
            f"{e['slenderness']:>4g} {e['method']:<9} {e['model']:<12} {par:>6} {res:>6} {cond:>8}   {'  '.join(cells)}"
        )


def plot(points, slenderness, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(slenderness), figsize=(4.2 * len(slenderness), 7), sharey=True, squeeze=False)
    colours = {"beam theory": "0.55", "N = 2": "C3", "N = 4": "C0", "N = 6": "C2", "beam K + N = 6": "C1"}
    markers = dict(zip(SWEEPS, "osd^", strict=True))
    for col, s in enumerate(slenderness):
        for row, method in enumerate(("twist", "dualquat")):
            ax = axes[row, col]
            for name, colour in colours.items():
                pts = points[s][f"{method} {name}"]
                for case, marker in markers.items():
                    sel = [r for r in pts if r["case"] == case]
                    ok = [r for r in sel if r["tip_error_pct_L"] is not None]
                    ax.plot([abs(r["tip_rotation_deg"]) for r in ok], [max(r["tip_error_pct_L"], 1e-4) for r in ok],
                            marker=marker, ms=3.5, lw=0.8, color=colour,
                            label=name if case == "transverse force" else None)  # fmt: skip
                    bad = [abs(r["tip_rotation_deg"]) for r in sel if r["tip_error_pct_L"] is None]
                    ax.plot(bad, [150.0] * len(bad), "x", color=colour, ms=6)
            ax.set_yscale("log")
            ax.set_ylim(1e-3, 300)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_title(f"L/t = {s:g}, {method}", fontsize=10)
            if row == 1:
                ax.set_xlabel("tip rotation of the reference chain [deg]")
            if col == 0:
                ax.set_ylabel("tip-position error [% of L]")
    axes[0, 0].legend(loc="lower right", fontsize=8, title="potential", title_fontsize=8)
    fig.suptitle("One fitted element vs a chain of 40 under held-out tip loads (x at the top: no stable equilibrium;"
                 " markers: " + ", ".join(f"{m} {c}" for c, m in markers.items()) + ")", fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=90)  # keeps the PNG under 300 kB (docs/fit_flexure.png)
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--slenderness", type=float, nargs="+", default=[10.0, 25.0, 100.0], help="L/t of the leaves")
    ap.add_argument("--segments", type=int, default=40, help="elements of the reference chain")
    ap.add_argument("--train", type=int, default=150, help="random training loads (plus 1/8 small ones)")
    ap.add_argument("--sweep-points", type=int, default=8, help="loads per held-out sweep")
    ap.add_argument("--weights", choices=("compliance", "rms"), default="compliance")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="out/fit_flexure")
    args = ap.parse_args()
    t0 = time.perf_counter()
    rng = np.random.default_rng(args.seed)
    table, points, potentials = [], {}, {}
    for s in args.slenderness:
        rows, points[s], potentials[f"L/t = {s:g}"] = study(s, args, rng)
        print_table(rows)
        table += rows
    os.makedirs(args.out, exist_ok=True)
    write_json(os.path.join(args.out, "fit_flexure.json"), {
        "leaf": {"L": L, "b": WIDTH, "E": E, "nu": NU, "segments": args.segments},
        "arguments": vars(args), "table": table,
        "points": {f"L/t = {s:g}": v for s, v in points.items()}, "potentials": potentials,
    })  # fmt: skip
    plot(points, args.slenderness, os.path.join(args.out, "fit_flexure.png"))
    s, method = args.slenderness[0], "twist"
    write_model(potentials[f"L/t = {s:g}"][f"{method} N = 6"], method, s, args.out)
    print(f"total {time.perf_counter() - t0:.0f} s")


def write_model(potential, method, slenderness, out):
    """A MuJoCo model of the clamped leaf with the fitted element, checked against the core.

    The tip body (a steel block 4 x 8 x 8 mm at the leaf's end) hangs on the element, whose frames
    sit at the leaf's centre; loading the file back, the provider's wrench at a deflected pose must
    equal :func:`mjflex.wrench_on_b` with the fitted potential.
    """
    import mujoco

    K, terms = np.array(potential["K"]), mjflex.PolynomialTerms.from_dict(potential["terms"])
    K_beam = leaf_spring_stiffness(L, L / slenderness, WIDTH, E, NU, method="beam")
    K = K + np.diag(np.where(np.diag(K) == 0, K_beam.diagonal(), 0))
    spec = mujoco.MjSpec()
    spec.modelname = f"leaf_L{slenderness:g}_{method}_N{terms.order}"
    tip = spec.worldbody.add_body(name="tip", pos=[L + 0.002, 0, 0])
    tip.add_freejoint()
    tip.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.002, 0.004, 0.004], density=7800)
    mjflex.add_flexure(spec, "leaf", "world", "tip", pos=[L / 2, 0, 0], K=K, method=method, terms=terms,
                       source={"fitted_by": "scripts/fit_flexure.py", "slenderness": slenderness,
                               "out_of_plane": "diagonal of mjflex.geometry.leaf_spring_stiffness"})  # fmt: skip
    path = os.path.join(out, f"{spec.modelname}.xml")
    with open(path, "w") as f:
        f.write(spec.to_xml())
    model = mujoco.MjModel.from_xml_path(path)
    data = mujoco.MjData(model)
    data.qpos[:3] += [-0.004, 0.012, 0.0]
    data.qpos[3:7] = [np.cos(0.3), 0, 0, np.sin(0.3)]  # 0.6 rad about z
    mujoco.mj_forward(model, data)
    W = mjflex.Flexures(model).wrenches(data)[0]
    R = data.site_xmat.reshape(-1, 3, 3)
    ref = mjflex.wrench_on_b(R[0], data.site_xpos[0], R[1], data.site_xpos[1], K, method=method, terms=terms)
    err = np.linalg.norm(W - ref) / np.linalg.norm(ref)
    print(
        f"wrote {path}: a {len(terms)}-term element; provider vs core wrench at 34 deg: relative difference {err:.1e}"
    )
    if err > 1e-12:
        raise RuntimeError(f"the provider's wrench differs from the core's by {err:.3g}")


if __name__ == "__main__":
    main()
