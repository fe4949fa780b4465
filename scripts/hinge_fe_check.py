"""Error of the beam models of mjflex.geometry against 2-D finite elements of the same geometry.

Usage::

    python scripts/hinge_fe_check.py [--json out/hinge_fe_check.json]

Prints, for circular notch hinges over t/R and for leaf springs over L/t, the ratio of beam
compliance to finite-element compliance (1 = exact; < 1: the beam model is too stiff) for the
in-plane terms (axial x, in-plane shear y, compliant rotation rot_z), in plane stress and plane
strain, on two meshes (to show convergence). These numbers are quoted in the docstrings.
"""

import argparse

import numpy as np
from _bench import write_json

from mjflex.geometry import fe2d, hinges

E, NU, B = 3.5e9, 0.33, 0.0095  # the paper's hinge material (5 % of aluminium) and plate thickness
R = 0.004
MESHES = ((120, 6), (240, 8))


def notch_row(ratio, plane):
    t = ratio * R
    H = t + 2 * R

    def h(x):  # the notch, continued by a block of length R on each side
        return hinges.notch_hinge_thickness(x, R, t) if abs(x) <= R else H

    beam = hinges._beam_compliance(h, 2 * R, B, E, NU, plane == "strain")
    out = []
    for nx, ny in MESHES:
        C = np.diag(fe2d.centre_compliance(h, 2 * R, B, E, NU, plane=plane, nx=nx, ny=ny))
        out.append({"x": beam[3] / C[0], "y": beam[4] / C[1], "rot_z": beam[2] / C[2]})
    return out


def leaf_row(l_over_t, plane):
    t = 0.0005
    L = l_over_t * t
    beam = hinges._beam_compliance(lambda x: t, L / 2, B, E, NU, plane == "strain")
    out = []
    for nx, ny in ((40, 4), (80, 6)):
        C = np.diag(fe2d.centre_compliance(lambda x: t, L / 2, B, E, NU, plane=plane, nx=nx, ny=ny, grading=1.0))
        out.append({"x": beam[3] / C[0], "y": beam[4] / C[1], "rot_z": beam[2] / C[2]})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/hinge_fe_check.json")
    args = ap.parse_args()
    result = {"notch": {}, "leaf": {}}
    for plane in ("stress", "strain"):
        print(f"\nnotch hinge, plane {plane}: beam / FE compliance (coarse mesh | fine mesh)")
        print(f"{'t/R':>6} {'axial x':>17} {'shear y':>17} {'rotation z':>17}")
        for ratio in (0.05, 0.1, 0.125, 0.2, 0.3, 0.5, 0.8):
            rows = notch_row(ratio, plane)
            result["notch"][f"{plane}:{ratio}"] = rows
            cells = [f"{rows[0][k]:.3f} | {rows[1][k]:.3f}" for k in ("x", "y", "rot_z")]
            print(f"{ratio:>6} {cells[0]:>17} {cells[1]:>17} {cells[2]:>17}")
        print(f"\nleaf spring between rigid clamps, plane {plane}: beam / FE compliance")
        print(f"{'L/t':>6} {'axial x':>17} {'shear y':>17} {'rotation z':>17}")
        for l_over_t in (5, 10, 18, 40):
            rows = leaf_row(l_over_t, plane)
            result["leaf"][f"{plane}:{l_over_t}"] = rows
            cells = [f"{rows[0][k]:.3f} | {rows[1][k]:.3f}" for k in ("x", "y", "rot_z")]
            print(f"{l_over_t:>6} {cells[0]:>17} {cells[1]:>17} {cells[2]:>17}")
    write_json(args.json, result)


if __name__ == "__main__":
    main()
