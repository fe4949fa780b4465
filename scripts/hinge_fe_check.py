"""Mesh convergence of the flexure finite elements, and the beam models' error against them.

Usage::

    python scripts/hinge_fe_check.py [--json out/hinge_fe_check.json]

1. Mesh convergence (plane stress, the tables' meshes at levels 1-4, every element count
   doubled per level): compliances of the in-plane entries, the observed order, the
   Richardson-extrapolated value and each level's error against it, for notch hinges
   (t/R = 0.05, 0.3, 1) and leaf springs (L/t = 1, 4, 32).
2. 3-D convergence at the paper's hinge and leaf: the tables' mesh, the same refined in the
   plane, and refined across the width.
3. Beam model vs 3-D finite elements (the tables' mesh, blocks subtracted): stiffness ratio
   K_beam / K_FE per diagonal entry over t/R and L/t, with the paper's width and material
   (> 1: the beam model is too stiff). ``wide`` is the beam model's default modulus switch.
"""

import argparse
import time

import numpy as np
from _bench import write_json

from mjflex.geometry import fe, hinges
from mjflex.geometry.fe_mesh import Counts

E, NU, B = 3.5e9, 0.33, 0.0095  # the paper's hinge material (5 % of aluminium) and plate thickness
R, T_LEAF = 0.004, 0.0005
ENTRIES = ["rot_x", "rot_y", "rot_z", "x", "y", "z"]


def convergence_2d(profile, counts):
    c = np.array([np.diag(fe.element_compliance(profile, B, E, NU, model="plane_stress", level=lev, counts=counts))
                  [[2, 3, 4]] for lev in (1, 2, 3, 4)])  # fmt: skip
    with np.errstate(invalid="ignore", divide="ignore"):
        order = np.log2((c[2] - c[1]) / (c[3] - c[2]))
    # where the differences reach round-off (no clean order), take the finest level as converged
    clean = np.isfinite(order) & (order > 1.0)
    extrapolated = np.where(clean, c[3] + (c[3] - c[2]) / (2.0 ** np.where(clean, order, 4.0) - 1.0), c[3])
    return c, order, extrapolated


def convergence_3d(profile, counts):
    fine_plane = Counts(2 * counts.flexure, 2 * counts.block, 2 * counts.thin, 2 * counts.outer, counts.width)
    fine_width = Counts(counts.flexure, counts.block, counts.thin, counts.outer, 2 * counts.width)
    c = [np.diag(fe.element_compliance(profile, B, E, NU, counts=k)) for k in (counts, fine_plane, fine_width)]
    # order-4 Richardson in each direction, errors added (they are independent to leading order)
    extrapolated = c[0] + (c[1] - c[0]) * 16 / 15 + (c[2] - c[0]) * 16 / 15
    return c, extrapolated


def print_convergence(result):
    print("\n1. mesh convergence, plane stress: compliance error of each level vs Richardson [%], observed order")
    for name, rows in result.items():
        print(f"\n{name}")
        print(f"{'':>10} {'rot_z':>9} {'x':>9} {'y':>9}")
        for key, row in rows.items():
            if key.startswith("level"):
                print(f"{key:>10} " + " ".join(f"{v:9.4f}" for v in row))
        print(f"{'order':>10} " + " ".join(f"{v:9.2f}" for v in rows["order"]))


def beam_vs_fe():
    rows = {}
    for ratio in (0.05, 0.125, 0.3, 0.5, 0.8, 1.0):
        t = ratio * R
        K_fe = np.diag(hinges.notch_hinge_stiffness(R, t, B, E, NU, method="fe"))
        beam = np.diag(hinges.notch_hinge_stiffness(R, t, B, E, NU, method="beam", allow_out_of_range=True))
        rows[f"notch t/R={ratio}"] = (beam / K_fe).tolist()
    for l_over_t in (2, 5, 18, 40):
        L = l_over_t * T_LEAF
        K_fe = np.diag(hinges.leaf_spring_stiffness(L, T_LEAF, B, E, NU, method="fe"))
        beam = np.diag(hinges.leaf_spring_stiffness(L, T_LEAF, B, E, NU, method="beam", allow_out_of_range=True))
        rows[f"leaf L/t={l_over_t}"] = (beam / K_fe).tolist()
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/hinge_fe_check.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    conv = {}
    cases = [(f"notch t/R={r}", fe.notch_profile(R, r * R), fe.NOTCH_COUNTS) for r in (0.05, 0.3, 1.0)]
    cases += [(f"leaf L/t={r}", fe.leaf_profile(r * T_LEAF, T_LEAF, 10 * T_LEAF), fe.LEAF_COUNTS) for r in (1, 4, 32)]
    for name, profile, counts in cases:
        c, order, ext = convergence_2d(profile, counts)
        conv[name] = {f"level {k + 1}": (100 * (c[k] / ext - 1)).tolist() for k in range(4)}
        conv[name]["order"] = order.tolist()
        conv[name]["extrapolated"] = ext.tolist()
    print_convergence(conv)
    print("\n2. 3-D, the paper's flexures: error of the tables' mesh vs refined meshes [%]")
    print(f"{'':>22} " + " ".join(f"{e:>8}" for e in ENTRIES))
    conv3 = {}
    paper = [("notch t/R=0.125", fe.notch_profile(R, 0.125 * R), fe.NOTCH_COUNTS),
             ("leaf L/t=18", fe.leaf_profile(18 * T_LEAF, T_LEAF, 10 * T_LEAF), fe.LEAF_COUNTS)]  # fmt: skip
    for name, profile, counts in paper:
        c, ext = convergence_3d(profile, counts)
        labels = ("tables' mesh", "refined in plane", "refined across width")
        conv3[name] = {k: (100 * (ci / ext - 1)).tolist() for k, ci in zip(labels, c, strict=True)}
        print(name)
        for k in labels:
            print(f"{k:>22} " + " ".join(f"{v:8.3f}" for v in conv3[name][k]))
    print("\n3. beam model / 3-D finite elements (stiffness ratio; > 1: beam too stiff)")
    print(f"{'':>16} " + " ".join(f"{e:>8}" for e in ENTRIES))
    ratios = beam_vs_fe()
    for name, row in ratios.items():
        print(f"{name:>16} " + " ".join(f"{v:8.3f}" for v in row))
    wall = time.perf_counter() - t0
    print(f"\nwall time {wall:.0f} s")
    write_json(args.json, {"convergence_2d": conv, "convergence_3d": conv3, "beam_over_fe": ratios, "wall_s": wall})


if __name__ == "__main__":
    main()
