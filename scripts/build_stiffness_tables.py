"""Generate the finite-element stiffness tables of notch hinges and leaf springs (package data).

Usage::

    python scripts/build_stiffness_tables.py [--kind notch leaf] [--jobs 1] [--out mjflex/geometry/data]

For every grid point it solves the 3-D elasticity problem of the flexure with its blocks
(:func:`mjflex.geometry.fe.element_compliance`, quadratic hexahedra, blocks subtracted) and
stores the factors ``K_FE / K_beam`` of the six diagonal entries. Then it measures the table's
error per entry, in two parts that add up to the stated band:

* interpolation: the table against finite elements on the same mesh at off-grid points
  (geometric midpoints of the grid cells, Poisson ratios between the tabulated ones);
* discretisation: the table's mesh against a Richardson extrapolation (order 4, the rate the
  quadratic elements show, see ``scripts/hinge_fe_check.py``) of the same mesh refined twice
  in the plane and, separately, twice across the width, at representative points.

Stiffness scales with E and with the size (K_rot ~ E L^3, K_trans ~ E L), so the grids are in
dimensionless ratios only; R = 1 m (notch) or t = 1 m (leaf) and E = 1 Pa are used.
Prints the wall time: about 10 minutes (notch) and 25 minutes (leaf) on one core of the
development machine. ``--reuse`` keeps the grid points of the existing table that the grid
still has (same mesh), e.g. after refining an axis.
"""

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from mjflex.geometry import fe, hinges
from mjflex.geometry.fe_mesh import Counts
from mjflex.geometry.tables import LEAF_BLOCK_HEIGHT, TABLE_FILES

ENTRIES = ["rot_x", "rot_y", "rot_z", "x", "y", "z"]
NUS = [0.2, 0.325, 0.45]
GRIDS = {
    "notch": {"t_over_R": list(np.geomspace(0.05, 1.0, 9)), "b_over_R": list(np.geomspace(0.25, 10.0, 6)),
              "nu": NUS},
    "leaf": {"L_over_t": list(np.geomspace(1.0, 64.0, 7)), "b_over_t": list(np.geomspace(1.0, 40.0, 7)), "nu": NUS},
}  # fmt: skip
#: Meshes of the tables (level 1 of these counts).
COUNTS = {"notch": fe.NOTCH_COUNTS, "leaf": fe.LEAF_COUNTS}
#: Representative points of the discretisation study (ratio_1, ratio_2, nu).
CONVERGENCE_POINTS = {"notch": [(0.05, 2.0, 0.33), (0.2, 0.5, 0.33), (0.8, 5.0, 0.33)],
                      "leaf": [(1.5, 3.0, 0.33), (6.0, 20.0, 0.33)]}  # fmt: skip


def beam_compliance(kind, r1, r2, nu):
    """Diagonal compliance (6,) of the beam formula with modulus E = 1 (the tables' reference)."""
    if kind == "notch":
        return hinges._beam_compliance(lambda x: hinges.notch_hinge_thickness(x, 1.0, r1), 1.0, r2, 1.0, nu, False)
    return hinges._beam_compliance(lambda x: 1.0, 0.5 * r1, r2, 1.0, nu, False)


def profile_of(kind, r1, r2):
    if kind == "notch":
        return fe.notch_profile(1.0, r1), r2
    return fe.leaf_profile(r1, 1.0, LEAF_BLOCK_HEIGHT), r2


def factors(kind, r1, r2, nu, counts=None, level=1):
    """``K_FE / K_beam`` (6,) at one point."""
    profile, b = profile_of(kind, r1, r2)
    C = fe.element_compliance(profile, b, 1.0, nu, model="solid", level=level, counts=counts or COUNTS[kind])
    return beam_compliance(kind, r1, r2, nu) / np.diag(C)


def _task(args):
    return factors(*args)


def _stored_factors(path, kind):
    """``{(r1, r2, nu): factors}`` of a previous table on the same mesh (for --reuse), else empty."""
    if not path or not os.path.exists(path):
        return {}
    with open(path) as fh:
        old = json.load(fh)
    if old["mesh"] != COUNTS[kind].__dict__:
        return {}
    a, b, c = (old["axes"][k] for k in old["axis_names"])
    f = old["factors"]
    return {(x, y, z): f[i][j][k] for i, x in enumerate(a) for j, y in enumerate(b) for k, z in enumerate(c)}


def run_grid(kind, jobs, reuse=None):
    axes = GRIDS[kind]
    names = list(axes)
    points = [(kind, a, b, n) for a in axes[names[0]] for b in axes[names[1]] for n in axes[names[2]]]
    stored = _stored_factors(reuse, kind)
    todo = [p for p in points if p[1:] not in stored]
    with ProcessPoolExecutor(jobs) as pool:
        computed = dict(zip([p[1:] for p in todo], pool.map(_task, todo, chunksize=2), strict=True))
    print(f"{kind}: {len(todo)} FE solutions, {len(points) - len(todo)} reused from {reuse}")
    values = [computed[p[1:]] if p[1:] in computed else stored[p[1:]] for p in points]
    shape = [len(axes[k]) for k in names] + [6]
    return np.array(values).reshape(shape)


def validation_points(kind):
    """Off-grid points: geometric midpoints of alternate grid cells, nu between the tabulated values."""
    axes = GRIDS[kind]
    names = list(axes)
    a, b = np.asarray(axes[names[0]]), np.asarray(axes[names[1]])
    ma, mb = np.sqrt(a[1:] * a[:-1]), np.sqrt(b[1:] * b[:-1])
    nus = [0.26, 0.39]
    pts = []
    for i, x in enumerate(ma):
        for j, y in enumerate(mb):
            if (i + j) % 2 == 0:
                pts.append((kind, float(x), float(y), nus[(i // 2 + j) % 2]))
    return pts


def interpolation_errors(kind, table, jobs):
    from mjflex.geometry import tables

    pts = validation_points(kind)
    with ProcessPoolExecutor(jobs) as pool:
        exact = list(pool.map(_task, pts, chunksize=1))
    rows = []
    for p, f_fe in zip(pts, exact, strict=True):
        f_tab = tables.correction_factors_from(table, p[1], p[2], p[3])
        rows.append({"point": p[1:], "error": (f_tab / f_fe - 1.0).tolist()})
    return rows


def discretisation_errors(kind):
    """Table mesh vs Richardson extrapolation (order 4) of in-plane and width refinements."""
    rows = []
    base = COUNTS[kind]
    for r1, r2, nu in CONVERGENCE_POINTS[kind]:
        f1 = factors(kind, r1, r2, nu, base)
        f_plane = factors(kind, r1, r2, nu, Counts(2 * base.flexure, 2 * base.block, 2 * base.thin, 2 * base.outer,
                                                   base.width))  # fmt: skip
        f_width = factors(kind, r1, r2, nu, Counts(base.flexure, base.block, base.thin, base.outer, 2 * base.width))
        # compliance errors add: extrapolate each refinement direction, combine
        c1, cp, cw = 1 / f1, 1 / f_plane, 1 / f_width
        c_inf = c1 + (cp - c1) * 16 / 15 + (cw - c1) * 16 / 15
        rows.append({"point": [r1, r2, nu], "table_mesh": f1.tolist(), "plane_refined": f_plane.tolist(),
                     "width_refined": f_width.tolist(), "error": (f1 * c_inf - 1.0).tolist()})  # fmt: skip
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", nargs="+", default=["notch", "leaf"], choices=["notch", "leaf"])
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "mjflex", "geometry", "data"))
    ap.add_argument("--reuse", action="store_true", help="reuse grid points of the existing table (same mesh)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    from mjflex.geometry import tables

    for kind in args.kind:
        t0 = time.perf_counter()
        path = os.path.join(args.out, TABLE_FILES[kind])
        f = run_grid(kind, args.jobs, path if args.reuse else None)
        table = {"kind": kind, "axis_names": list(GRIDS[kind]), "axes": GRIDS[kind], "entries": ENTRIES,
                 "factors": f.tolist(), "mesh": COUNTS[kind].__dict__}  # fmt: skip
        table["grid_wall_time_s"] = time.perf_counter() - t0
        if kind == "leaf":
            table["block_height_over_t"] = LEAF_BLOCK_HEIGHT
        t1 = time.perf_counter()
        interp = interpolation_errors(kind, table, args.jobs)
        disc = discretisation_errors(kind)
        band = {}
        for i, e in enumerate(ENTRIES):
            ei = max(abs(r["error"][i]) for r in interp)
            ed = max(abs(r["error"][i]) for r in disc)
            band[e] = {"interpolation": ei, "discretisation": ed, "total": ei + ed}
        table.update(
            validation=interp,
            convergence=disc,
            error_band=band,
            validation_wall_time_s=time.perf_counter() - t1,
            command=f"python scripts/build_stiffness_tables.py --kind {kind} --jobs {args.jobs}",
        )
        with open(path, "w") as fh:
            json.dump(table, fh, indent=None, separators=(",", ":"))
            fh.write("\n")
        tables.load_table.cache_clear()
        print(f"\n{kind}: grid of {f.shape[0] * f.shape[1] * f.shape[2]} in {table['grid_wall_time_s']:.0f} s, "
              f"validation {table['validation_wall_time_s']:.0f} s -> {os.path.normpath(path)}")  # fmt: skip
        print(f"{'entry':>6} {'interp %':>9} {'mesh %':>8} {'band %':>8}")
        for e in ENTRIES:
            b = band[e]
            print(f"{e:>6} {100 * b['interpolation']:9.3f} {100 * b['discretisation']:8.3f} {100 * b['total']:8.3f}")


if __name__ == "__main__":
    main()
