"""Linearized modal analysis of the ARCADE model: is the cylinder's axial translation the lowest mode?

Usage::

    python scripts/modes.py [MODEL.xml ...] [--count 12] [--json out/modes.json]

For each model (default ``models/arcade.xml`` and ``models/arcade_rigid.xml``) assembles the
mass matrix (``mj_fullM``) and the flexures' tangent stiffness (central differences of the
generalized forces through MuJoCo's kinematics) at ``qpos0``, solves ``K phi = w^2 M phi``
and prints the first modes with the bodies that carry their kinetic energy. The guide works
when, after the six free-floating rigid modes, the lowest mode is the cylinder translating
along its axis relative to the base; the ratio to the next frequency is its separation.
"""

import argparse
import os

import mujoco
from _bench import write_json

import mjflex
from mjflex.app.modes import guide_report

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "models", nargs="*", default=[os.path.join(HERE, "..", "models", f) for f in ("arcade.xml", "arcade_rigid.xml")]
    )
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--json", default="out/modes.json")
    args = ap.parse_args()
    results = {}
    for path in args.models:
        model = mujoco.MjModel.from_xml_path(path)
        report = guide_report(model, mjflex.Flexures(model), count=args.count)
        results[os.path.basename(path)] = report
        print(f"\n{os.path.basename(path)}: {model.nbody - 1} bodies, nv = {model.nv}")
        print(f"{'#':>3} {'f [Hz]':>10}  {'axial':>6} {'cyl KE':>7}  bodies carrying the kinetic energy")
        for m in report["modes"]:
            kind = "rigid" if m["rigid"] else f"{m['axial_fraction']:.3f}"
            bodies = ", ".join(f"{n} {s:.2f}" for n, s in m["top_bodies"])
            flag = "  <- cylinder axial translation" if m["is_axial_translation"] else ""
            print(f"{m['index']:>3} {m['frequency_hz']:>10.3f}  {kind:>6} {m['moving_share']:>7.2f}  {bodies}{flag}")
        verdict = "IS" if report["guide_is_axial"] else "is NOT"
        print(
            f"lowest non-rigid mode (#{report['guide_mode']}, {report['guide_frequency_hz']:.2f} Hz) {verdict} the "
            f"cylinder's axial translation; next mode is {report['separation']:.2f}x higher; highest mode "
            f"{report['highest_frequency_hz']:.0f} Hz"
        )
    write_json(args.json, results)


if __name__ == "__main__":
    main()
