"""Bad plugin configurations are MuJoCo compile errors that name the element and the fix; nothing loads half.

The plugin's init (mjflex/native/config.c) applies the text record's rules; each case is also checked
against Python's reading of a configuration (mjflex.mjcf.config.record_from_config), which must reject it too.
"""

import json
import re

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.mjcf.config import record_from_config

BASE = {"site_a": "e/a", "site_b": "e/b", "K": "1 2 3 1000 2000 3000"}

XML = """
<mujoco model="bad">
  <extension><plugin plugin="{plugin}">
    <instance name="e">{config}</instance>
  </plugin></extension>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="A"><freejoint/><geom size="0.05"/><site name="e/a" pos="0.05 0 0"/></body>
    <body name="B" pos="0.1 0 0"><freejoint/><geom size="0.05"/><site name="e/b" pos="{pos_b}"/></body>
  </worldbody>
  <contact><exclude body1="A" body2="B"/></contact>
  {extra}
</mujoco>
"""


def _xml(config, plugin="mjflex.flexure", pos_b="-0.05 0 0", extra=""):
    rows = "".join(f'<config key="{k}" value="{v}"/>' for k, v in config.items())
    return XML.format(plugin=plugin, config=rows, pos_b=pos_b, extra=extra)


def _config(**changes):
    config = dict(BASE)
    for key, value in changes.items():
        if value is None:
            config.pop(key)
        else:
            config[key] = value
    return config


ASYMMETRIC = np.diag([1.0, 2, 3, 1000, 2000, 3000])
ASYMMETRIC[0, 1] = 0.5
INDEFINITE = np.diag([1.0, 2, 3, 1000, 2000, 3000])
INDEFINITE[0, 3] = INDEFINITE[3, 0] = 100.0  # |K_03| > sqrt(K_00 K_33)


def _flat(M):
    return " ".join(repr(float(v)) for v in M.ravel())


# (config changes, the problem the message states, the fix it names)
CASES = {
    "K missing": ({"K": None}, r"K is missing", r"give 6 numbers \(the diagonal\) or 36"),
    "K not a number": ({"K": "1 2 x 4 5 6"}, r"K has 'x', which is not a number", r"numbers separated by spaces"),
    "K of 5 numbers": ({"K": "1 2 3 4 5"}, r"K has 5 numbers", r"Give 6 numbers \(the diagonal\) or 36"),
    "K NaN": ({"K": "nan 2 3 4 5 6"}, r"K\[0, 0\] = nan is not finite", r"Fix K"),
    "K infinite": ({"K": "1 2 3 inf 5 6"}, r"K\[3, 3\] = inf is not finite", r"Fix K"),
    "K beyond 1e280": ({"K": "1 2 3 1e300 5 6"}, r"K\[3, 3\] = 1e\+300 is beyond 1e\+280", r"check its units"),
    "K not symmetric": (
        {"K": _flat(ASYMMETRIC)},
        r"K is not symmetric: K\[0, 1\] = 0.5 but K\[1, 0\] = 0",
        r"write \(M \+ M\^T\) / 2",
    ),
    "K indefinite": ({"K": _flat(INDEFINITE)}, r"K is not positive semi-definite", r"coupling block K_c"),
    "B of another size": ({"B": "1 2 3"}, r"B has 3 numbers", r"Give 6 or 36 numbers, as K"),
    "B indefinite": ({"B": "1 -2 3 4 5 6"}, r"B is not positive semi-definite", r"generates energy"),
    "method misspelt": ({"method": "twst"}, r"unknown method 'twst'", r'Use method "twist" or "dualquat"'),
    "switch not a boolean": ({"enabled": "yes"}, r"enabled must be true or false; got 'yes'", r"true or false"),
    "odd dualquat order": (
        {"method": "dualquat", "order": "3", "exponents": "0 0 0 0 0 2 0 0", "coefficients": "1"},
        r"order must be an integer >= 2 and even",
        r"Fix order",
    ),
    "exponents not in rows": (
        {"order": "3", "exponents": "0 0 3 0 0", "coefficients": "1"},
        r"exponents has 5 integers, not a multiple of 6",
        r"one row of 6 exponents",
    ),
    "a coefficient too few": (
        {"order": "3", "exponents": "0 0 3 0 0 0 3 0 0 0 0 0", "coefficients": "1"},
        r"2 rows of exponents but 1 coefficients",
        r"one coefficient per term",
    ),
    "a linear term": ({"order": "3", "exponents": "0 0 1 0 0 0", "coefficients": "1"}, r"is a linear term", r"drop it"),
    "terms above the default order": (
        {"exponents": "0 0 3 0 0 0", "coefficients": "1"},
        r"exponents row 0 has degree 3, above order 2",
        r"raise order",
    ),
    "negative strain": (
        {"strain_per_radian": "-1"},
        r"strain_per_radian must be a finite number >= 0",
        r"got '-1'",
    ),
    "source not JSON": ({"source": "{formula: 1}"}, r"source must be one JSON object", r"standard JSON"),
    "site_a missing": ({"site_a": None}, r"site_a is missing", r'value="SITE"'),
    "site_b unknown": ({"site_b": "e/c"}, r"site_b 'e/c' is not a site of the model", r'Add <site name="e/c"/>'),
}
MODEL_ONLY = {"site_a missing", "site_b unknown"}  # Python checks sites against a model, not in the config


@pytest.mark.parametrize("case", list(CASES))
def test_bad_configuration_is_a_compile_error_naming_the_element(case):
    changes, problem, fix = CASES[case]
    with pytest.raises(ValueError) as info:
        mujoco.MjModel.from_xml_string(_xml(_config(**changes)))
    text = str(info.value)
    assert "flexure 'e' (plugin instance of mjflex.flexure)" in text
    assert re.search(problem, text), text
    assert re.search(fix, text), text
    if case not in MODEL_ONLY:  # Python's reading of the configuration rejects it as well
        with pytest.raises(ValueError):
            record_from_config("e", _config(**changes))
    else:
        record_from_config("e", _config(**changes) | {"site_a": "x", "site_b": "y"})


def test_the_valid_base_compiles_and_both_readings_agree():
    model = mujoco.MjModel.from_xml_string(_xml(BASE))
    assert model.nplugin == 1
    record = record_from_config("e", BASE)
    assert np.array_equal(record.K, np.diag([1.0, 2, 3, 1000, 2000, 3000]))


def test_sites_that_do_not_coincide():
    with pytest.raises(ValueError, match=r"flexure 'e' .*sites 'e/a' and 'e/b' are 0.01 m apart .*place both at"):
        mujoco.MjModel.from_xml_string(_xml(BASE, pos_b="-0.04 0 0"))


def test_both_sites_on_one_body():
    with pytest.raises(ValueError, match=r"flexure 'e' .*both sites are on body 'A'. Put site_a on one body"):
        mujoco.MjModel.from_xml_string(_xml(_config(site_b="e/a")))


def test_unknown_attribute_and_misspelt_plugin_are_muJoCos_own_errors():
    with pytest.raises(ValueError, match=r"unrecognized attribute 'plugin:stiffness' for plugin mjflex.flexure"):
        mujoco.MjModel.from_xml_string(_xml(_config(stiffness="1")))
    with pytest.raises(ValueError, match=r"(?i)unknown plugin|unrecognized plugin|mjflex.flexur\b"):
        mujoco.MjModel.from_xml_string(_xml(BASE, plugin="mjflex.flexur"))


def test_an_element_written_both_ways_is_an_error():
    record = '<custom><text name="mjflex:e" data=\'{"mjflex": 1, "K": [1, 2, 3, 1000, 2000, 3000]}\'/></custom>'
    with pytest.raises(ValueError, match=r"flexure 'e' is both a plugin instance and the text record 'mjflex:e'"):
        mujoco.MjModel.from_xml_string(_xml(BASE, extra=record))


def test_an_instance_needs_a_name():
    """An implicit instance (a <plugin> with its config inside a body) has no name to know the element by."""
    rows = "".join(f'<config key="{k}" value="{v}"/>' for k, v in BASE.items())
    xml = _xml(BASE).replace(
        '<site name="e/b" pos="-0.05 0 0"/>',
        f'<site name="e/b" pos="-0.05 0 0"/><plugin plugin="mjflex.flexure">{rows}</plugin>',
    )
    with pytest.raises(ValueError, match=r"instance 1\) has no name; an element is known by its name.*<instance name="):
        mujoco.MjModel.from_xml_string(xml)


def test_nothing_loads_half():
    """One bad instance among good ones: no model at all (and the good instances' memory is freed)."""
    good = "".join(f'<config key="{k}" value="{v}"/>' for k, v in BASE.items())
    bad = good.replace('value="1 2 3 1000 2000 3000"', 'value="1 2 3 -1000 2000 3000"')
    xml = _xml(BASE).replace(
        f'<instance name="e">{good}</instance>',
        f'<instance name="e">{good}</instance><instance name="f">{bad}</instance>',
    )
    with pytest.raises(ValueError, match=r"flexure 'f' .*K is not positive semi-definite"):
        mujoco.MjModel.from_xml_string(xml)
    spec = mujoco.MjSpec.from_string(xml)
    with pytest.raises(ValueError, match=r"flexure 'f'"):
        spec.compile()
    # failed compiles leave no instance alive (the failing init frees itself and the instances before it)
    from mjflex.native import library as _native

    alive = _native.lib().mjfx_live_instances()
    for _ in range(20):
        with pytest.raises(ValueError):
            mujoco.MjModel.from_xml_string(xml)
    assert _native.lib().mjfx_live_instances() == alive


def test_source_is_kept_verbatim():
    source = {"formula": "beam", "E": 7e10, "nested": [1, {"a": None}]}
    config = _config(source=json.dumps(source).replace('"', "&quot;"))
    model = mujoco.MjModel.from_xml_string(_xml(config))
    assert mjflex.Flexures(model).records[0].source == source
