"""Units (issue 33 item 9): ``import mjflex.units``, and a K that cannot be meant for the bodies it holds.

A K in N m/deg or N/mm given as SI is 57 or 1000 times too soft: the body it holds would sag under gravity by more
than its own size. :class:`mjflex.Flexures` says so where it reads a model (once, at the boundary: both forms, any
file), with a :class:`mjflex.LikelyMistakeWarning` naming the element and suggesting :mod:`mjflex.units`; the same
elements in SI, and the repository's own models, say nothing.
"""

import subprocess
import sys
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex import units
from mjflex.runtime import plausibility
from tests.robots import K_HAND, arm_spec, pusher_path
from tests.spine import spine_spec

#: A lumbar disc as papers give it: 2 N m/deg about every axis, 500 N/mm along every axis.
DISC = [2.0] * 3 + [500.0] * 3
DISC_SI = [2.0 * units.N_m_per_deg] * 3 + [500.0 * units.N_per_mm] * 3


def test_import_mjflex_units_is_the_units_module():
    """1.0.0: ``from mjflex import units`` worked, ``import mjflex.units`` raised ModuleNotFoundError."""
    code = ("import mjflex.units, mjflex.core.units; from mjflex.units import N_m_per_deg; "
            "assert mjflex.units is mjflex.core.units; print(N_m_per_deg)")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert float(out) == pytest.approx(180 / np.pi, rel=1e-15)


def _flexures_quietly(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mjflex.Flexures(model)


@pytest.mark.parametrize("kind", ["record", "plugin"])
def test_a_disc_given_in_newton_metres_per_degree_is_said_to_be_in_other_units(kind):
    """The spine's L4 on an element instead of its three hinges (the torso's 2 kg above): 2 N m/deg and 500 N/mm
    written as SI let L4 and what it carries sag by several times L4's size; converted, by a few thousandths."""
    spec = spine_spec()
    with pytest.warns(mjflex.LikelyMistakeWarning, match="under gravity"):  # make_compliant reads it as Flexures
        mjflex.make_compliant(spec, "L4", DISC, replace_joints=True, kind=kind)
    model = spec.compile()
    with pytest.warns(mjflex.LikelyMistakeWarning) as caught:
        mjflex.Flexures(model)
    (message,) = [str(w.message) for w in caught if "under gravity" in str(w.message)]
    assert message.startswith("flexure 'L4_compliance': its K lets body 'L4' (") and "more than its size" in message
    assert "mjflex.units" in message and "N_m_per_deg" in message
    assert caught[0].filename == __file__  # attributed to the line that built the Flexures
    spec = spine_spec()
    mjflex.make_compliant(spec, "L4", DISC_SI, replace_joints=True, kind=kind)
    model = spec.compile()
    flex = _flexures_quietly(model)
    (sag,) = plausibility.sags(model, flex.records, flex.element_table.elements[: len(flex)])
    assert sag.sag < 0.01 * sag.size  # converted: a small fraction of the body


def test_the_sag_is_the_weight_over_the_stiffness_of_a_hanging_block():
    """A 0.5 kg block hanging from a leaf spring at its centre of mass: the sag is m g / k_z (no moment), checked
    against the closed form; 10 N/mm written as 10 N/m warns (0.49 m of sag for a 2 cm block), 1e4 N/m does not."""

    def model(k):
        spec = mujoco.MjSpec.from_string(
            '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
            '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
        )
        mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.1], K=[2, 2, 1, k, k, k])
        return spec.compile()

    soft = model(10.0)
    with pytest.warns(mjflex.LikelyMistakeWarning, match=r"flexure 'leaf': .* sag 0\.49\d* m .*translation"):
        flex = mjflex.Flexures(soft)
    (sag,) = plausibility.sags(soft, flex.records, flex.element_table.elements[:1])
    assert sag.sag == pytest.approx(0.5 * 9.81 / 10.0, rel=1e-12) and sag.mass == 0.5
    assert sag.size == pytest.approx(np.sqrt(3) * 0.02, rel=1e-12)  # the box's bounding sphere
    stiff = model(1e4)
    flex = _flexures_quietly(stiff)
    (sag,) = plausibility.sags(stiff, flex.records, flex.element_table.elements[:1])
    assert sag.sag == pytest.approx(0.5 * 9.81 / 1e4, rel=1e-12)


def test_end_stops_bound_the_sag_and_gravity_off_judges_nothing():
    spec = spine_spec()
    stops = mjflex.Stops(lower=[-0.05] * 3 + [-0.001] * 3, upper=[0.05] * 3 + [0.001] * 3)
    mjflex.make_compliant(spec, "L4", DISC, replace_joints=True, stops=stops)
    model = spec.compile()
    _flexures_quietly(model)  # the stops hold the body within 0.05 rad and 1 mm: plausible
    spec = spine_spec()
    with pytest.warns(mjflex.LikelyMistakeWarning, match="under gravity"):
        mjflex.make_compliant(spec, "L4", DISC, replace_joints=True)
    model = spec.compile()
    model.opt.gravity[:] = 0
    _flexures_quietly(model)


def test_the_repositorys_own_models_say_nothing():
    """ARCADE and the two-body models (no gravity), the spine with literature values in SI, the robot arm's hand and
    gymnasium's pusher forearm with the tests' stiffness (with gravity set): no warning."""
    for path in ("models/arcade.xml", "models/two_body.xml", "models/two_body_plugin.xml"):
        _flexures_quietly(mujoco.MjModel.from_xml_path(path))
    spec = spine_spec()
    for level in ("L5", "L4", "L3"):
        mjflex.make_compliant(spec, level, DISC_SI, replace_joints=True)
    _flexures_quietly(spec.compile())
    spec = arm_spec()
    mjflex.make_compliant(spec, "hand", K_HAND, replace_joints=True)
    arm = spec.compile()
    flex = _flexures_quietly(arm)
    assert plausibility.sags(arm, flex.records, flex.element_table.elements[:1])  # judged, and plausible
    spec = mujoco.MjSpec.from_file(pusher_path())
    mjflex.make_compliant(spec, "r_forearm_link", K=[400.0, 500.0, 300.0, 2e5, 3e5, 4e5],
                          pos=[0.02, 0.0, 0.0], quat=[0.7071068, 0.0, 0.7071068, 0.0], frame="parent")  # fmt: skip
    pusher = spec.compile()
    pusher.opt.gravity[:] = [0.0, 0.0, -9.81]
    flex = _flexures_quietly(pusher)
    assert plausibility.sags(pusher, flex.records, flex.element_table.elements[:1])
