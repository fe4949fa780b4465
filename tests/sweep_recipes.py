"""Module-level recipe edits and observers for tests/test_sweep.py (worker processes import them)."""

import mjflex
from mjflex.mjcf import elements
from mjflex.mjcf.elements import edit_flexure, flexure_matrices


def scale_hinge(spec, k_scale=1.0, b_scale=1.0):
    """Scale the stiffness and damping of ``models/two_body.xml``'s element ``hinge``."""
    K, B = flexure_matrices(spec, "hinge")
    edit_flexure(spec, "hinge", K=k_scale * K, B=b_scale * B)


def hinge_state(model, flex, data):
    """Pose and velocity of block B, the hinge's wrench and energy."""
    return {
        "qpos": data.qpos[7:].copy(),
        "qvel": data.qvel[6:].copy(),
        "wrench": (("component",), flex.wrenches(data)[0]),
        "energy": flex.potential_energy(data),
    }


def stop_hinge(spec, limit=0.0, stiffness=0.0):
    """Give ``models/two_body.xml``'s element ``hinge`` end stops at +-``limit`` rad on its rotation about z (0: no
    stops), of ``stiffness`` N m/rad (0: derived from K)."""
    record = elements.element_record(spec, "hinge")
    none = [None] * 6
    record.stops = None
    if limit:
        record.stops = mjflex.Stops(lower=none[:2] + [-limit] + none[3:], upper=none[:2] + [limit] + none[3:],
                                    stiffness=stiffness or None)  # fmt: skip
    elements.write_record(spec, "hinge", record)
