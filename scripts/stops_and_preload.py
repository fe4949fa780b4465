"""Damped end stops against MuJoCo's joint limits, and a preload kept by a rest pose: the figures of
docs/background/end_stops.md.

Usage::

    python scripts/stops_and_preload.py [--json out/stops_and_preload.json]

The models and what is measured on them are tests/stop_models.py's (the test's own, not copied;
tests/test_stop_demos.py checks the claims and compares this JSON with a run of today's code):

* **a link dropped into a stop** at MuJoCo's Euler with a 2 ms step: MuJoCo's joint limit with ``solref = (TAU,
  ZETA)``, and element stops that are conservative (the derived 100 K_ii, or too stiff for the step) or damped
  from the same ``solref`` (``Stops(time_constant=TAU, damping_ratio=ZETA)``): each bounce's depth and energy
  loss, the energy lost in 1 s, and what a nudge of 1e-9 rad grows to after 1 s;
* **a parallel gripper's finger**, the 2F-85's four-bar linkage closed by a ``connect`` equality, its coupler
  pressed against its limit by the spring link's preloaded spring: the rigid finger (a joint spring with
  ``springref``), the spring as an element with a rest pose (the coupler's limit kept, or an element stop at a
  step where it holds the preload, and at 2 ms), and the element without the rest pose: the distance of each pad
  path from the rigid finger's, and the pad's tilt.

Nothing is timed: the JSON is the same on every run. Record with ``MJFLEX_RECORD=1`` (scripts/_bench.py), then
render the page with ``python scripts/results_blocks.py``.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # _bench: also imported by path
sys.path.append(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tests/stop_models.py (the test's)
from _bench import write_json

from tests.stop_models import figures


def summary(result):
    """The figures as text."""
    lines = []
    for variant, r in result["link"].items():
        depths = ", ".join(f"{d:.4f}" for d in r["rebounds_rad"][:6])
        lines.append(f"link, {variant:8s}: bounces {len(r['rebounds_rad'])}, depths {depths} rad; energy lost in 1 s "
                     f"{r['energy_lost_J']:.3g} J; a 1e-9 rad nudge after 1 s "
                     f"{r['nudge_after_1s_rad']:.2g} rad")  # fmt: skip
    for variant, r in result["finger"].items():
        lines.append(f"finger, {variant:18s}: pad path from the rigid finger's {r['path_from_rigid_m'] * 1e3:.3g} "
                     f"mm, largest tilt {r['largest_tilt_rad']:.3g} rad")  # fmt: skip
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=os.path.join("out", "stops_and_preload.json"))
    args = ap.parse_args()
    result = figures()
    print(summary(result))
    write_json(args.json, result)


if __name__ == "__main__":
    main()
