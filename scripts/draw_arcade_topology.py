"""Draw the topology of one ARCADE linkage plate (docs/arcade_topology.png).

Usage::

    python scripts/draw_arcade_topology.py [--out docs/arcade_topology.png]

The plate lies in the (r, z) half-plane of its angle; the other two plates are the same at
120 and 240 degrees. Bodies are drawn from the model's geoms, flexures from its element frames.
"""

import argparse
import os

import mujoco
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

import mjflex

HERE = os.path.dirname(os.path.abspath(__file__))
COLORS = {"base": "#3b3f4a", "cylinder": "#5b8bd9", "hub": "#d99a4e", "rod": "#9aa0aa", "leg": "#b9bec7"}


def _kind(name):
    for k in COLORS:
        if name.startswith(k):
            return k
    return "rod"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--out", default=os.path.join(HERE, "..", "docs", "arcade_topology.png"))
    args = ap.parse_args()
    model = mujoco.MjModel.from_xml_path(args.model)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    flex = mjflex.Flexures(model)
    fig = Figure(figsize=(7.5, 8))
    ax = fig.subplots()
    # plate 0 lies in the x-z plane (angle 0): r = x
    for g in range(model.ngeom):
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        p, R = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER:
            r, h = model.geom_size[g][:2]
            ax.add_patch(Rectangle((0, -h), r, 2 * h, color=COLORS["cylinder"], alpha=0.5))
            continue
        if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX or abs(p[1]) > 1e-6 or p[0] < 0:
            continue
        half = np.abs(R) @ model.geom_size[g]
        ax.add_patch(Rectangle((p[0] - half[0], p[2] - half[2]), 2 * half[0], 2 * half[2],
                               color=COLORS[_kind(body)], alpha=0.9))  # fmt: skip
        if body.startswith(("hub", "rod", "leg")) and "p0" in body:
            ax.text(p[0], p[2] + half[2] + 0.002, body.replace("_p0", ""), ha="center", va="bottom", fontsize=6)
        del name
    for e, name in enumerate(flex.names):
        if "_p0_" not in name:
            continue
        p = data.site_xpos[flex.site_ids[e, 0]]
        leaf = name.startswith("leaf")
        ax.plot(p[0], p[2], marker="s" if leaf else "o", color="#2a9d4b" if leaf else "#d33", ms=6)
    ax.plot([], [], "o", color="#d33", label="notch hinge (12 per plate)")
    ax.plot([], [], "s", color="#2a9d4b", label="leaf spring (4 per plate)")
    for k, c in COLORS.items():
        ax.add_patch(Rectangle((0, 0), 0, 0, color=c, label=k))
    ax.set_xlim(-0.005, 0.165)
    ax.set_ylim(-0.115, 0.115)
    ax.set_aspect("equal")
    ax.set_xlabel("r [m] (radial, in the plate)")
    ax.set_ylabel("z [m] (cylinder axis)")
    title = "ARCADE-like guide: one of three linkage plates (others at 120°, 240°)\n"
    title += "hub guided by 4 two-link legs to the base; cylinder guided by 2 rods to the hub"
    ax.set_title(title, fontsize=9)
    ax.legend(loc="center", bbox_to_anchor=(0.64, 0.5), fontsize=7)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
