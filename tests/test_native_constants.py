"""Constants that the C library and Python both hold are equal: each is defined once on each side of the ctypes
boundary (``mjflex/native/config.h``, ``elements.h``, ``flexure_math.h``; Python's modules named below) and read
from C through ``mjfx_constant``, so a change on one side alone fails here."""

import math

import mujoco
import numpy as np
import pytest

from mjflex.core import polynomial, rest, stops, validation
from mjflex.mjcf import schema
from mjflex.mjcf import stops as record_stops
from mjflex.native import library as _native
from mjflex.runtime import registry as _callback

PAIRS = {  # C name -> Python's value
    "MAX_MATRIX_ENTRY": validation.MAX_MATRIX_ENTRY,
    "SYMMETRY_RTOL": validation.SYMMETRY_RTOL,
    "PSD_RTOL": validation.PSD_RTOL,
    "REST_STRESS_RTOL": polynomial.REST_STRESS_RTOL,
    "REST_QUAT_TOLERANCE": rest.REST_QUAT_TOLERANCE,
    "MAX_EXPONENT": polynomial.MAX_EXPONENT,
    "TERM_COLUMNS": _native.TERM_COLUMNS,
    "STOP_STIFFNESS_FACTOR": stops.STIFFNESS_FACTOR,
    "MAX_ROTATION_LIMIT": record_stops.MAX_ROTATION_LIMIT,
    "MAX_STIFFNESS": record_stops.MAX_STIFFNESS,
    "NATTRIBUTE": len(schema.attributes()),
    "FORM_PLUGIN": 0,  # library.parse_values passes the form by its name, looked up here
    "FORM_RECORD": 1,
    "TWIST": validation.METHOD_CODES["twist"],
    "DUALQUAT": validation.METHOD_CODES["dualquat"],
    "FULL": _native.FULL,
    "DIAGONAL": _native.DIAGONAL,
    "ZERO": _native.ZERO,
    "APPLY": _native.APPLY,
    "WRENCH": _native.WRENCH,
    "ENERGY": _native.ENERGY,
    "POWER": _native.POWER,
    "COORDS": _native.COORDS,
}


@pytest.mark.parametrize("name", list(PAIRS))
def test_a_constant_of_both_sides_is_equal(name):
    assert _native.constant(name) == PAIRS[name], name


def test_the_lists_and_sizes_are_equal_too():
    assert math.isnan(_native.constant("NO_SUCH_CONSTANT"))
    assert _native.plugin_attributes() == tuple(a.key for a in schema.attributes())
    assert _native.lib().mjfx_registry_capacity() == _callback.CAPACITY
    assert _native.lib().mjfx_element_field(None) == _native.ELEMENT_DTYPE.itemsize


def test_a_planar_element_lands_on_the_planar_index():
    """stops.PLANAR_INDEX against C's embedding of a 3x3 K (config.c's PLANAR_INDEX): the row C lays out."""
    K3 = np.array([[0.4, 0.02, -0.01], [0.02, 90.0, 4.0], [-0.01, 4.0, 120.0]])
    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body name="b"><freejoint/><geom size="0.01" mass="0.1"/></body></worldbody></mujoco>'
    )
    import mjflex

    mjflex.add_flexure(spec, "p", "world", "b", pos=[0, 0, 0], K=K3)
    row = mjflex.Flexures(spec.compile()).element_table.elements[0]
    K6 = np.zeros((6, 6))
    K6[np.ix_(stops.PLANAR_INDEX, stops.PLANAR_INDEX)] = K3
    assert np.array_equal(row["K"].reshape(6, 6), K6)
