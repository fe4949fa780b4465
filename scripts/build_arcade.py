"""Generate models/arcade.xml (and the rigid-end-group variant) with mujoco.MjSpec.

Usage::

    python scripts/build_arcade.py [--out models] [--method twist|dualquat] [--kind plugin|record]

Writes ``arcade.xml`` (35 free bodies, 36 notch hinges, 12 leaf springs; topology in
``mjflex/app/arcade.py``) and ``arcade_rigid.xml`` (the three bodies near each end plate
welded: 31 bodies), then reloads both and checks the counts. The elements are instances of
the engine plugin ``mjflex.flexure`` (``--kind plugin``, the default: the files run in any
MuJoCo program, e.g. ``python -m mujoco.viewer --mjcf=models/arcade.xml``) or text records.
"""

import argparse
import os

import mujoco

import mjflex
from mjflex.app.arcade import build_arcade_spec


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "models"))
    ap.add_argument("--method", default="twist", choices=["twist", "dualquat"])
    ap.add_argument("--kind", default="plugin", choices=["plugin", "record"], help="how the elements are written")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for name, rigid in (("arcade.xml", False), ("arcade_rigid.xml", True)):
        path = os.path.join(args.out, name)
        with open(path, "w") as f:
            f.write(build_arcade_spec(method=args.method, rigid_end_groups=rigid, kind=args.kind).to_xml())
        model = mujoco.MjModel.from_xml_path(path)
        flex = mjflex.Flexures(model)
        notches = sum(n.startswith("notch_") for n in flex.names)
        leaves = sum(n.startswith("leaf_") for n in flex.names)
        print(
            f"wrote {os.path.normpath(path)}: {model.nbody - 1} bodies, {notches} notch hinges, {leaves} leaf springs"
        )


if __name__ == "__main__":
    main()
