"""tests/model_text.py: round-off passes, anything else that changes a model file fails and is named."""

import math
import os
import re

import pytest

import mjflex
from tests.model_text import ATOL_SCALE, RTOL, assert_xml_equivalent, compare_text, compare_xml, split_numbers

MODELS = os.path.join(os.path.dirname(__file__), "..", "models")
FLOAT = re.compile(r"(?<![\w.])-?\d+\.\d{6,}(?:e[-+]?\d+)?(?![\w.])")  # full-precision floats (JSON records)


@pytest.fixture(scope="module")
def arcade_xml(tmp_path_factory):
    """The committed ARCADE model with its elements as text records (JSON lists in CDATA), every digit kept."""
    path = str(tmp_path_factory.mktemp("arcade") / "arcade_records.xml")
    mjflex.convert_file(os.path.join(MODELS, "arcade.xml"), path, to="record")
    with open(path) as f:
        return f.read()


def _ulps(match, n=4):
    x = float(match.group())
    for _ in range(n):
        x = math.nextafter(x, math.inf)
    return repr(x)


def test_every_number_a_few_ulps_off_passes(arcade_xml):
    """What another CPU or another numpy/scipy/numba gives (1-4 ulps observed): every full-precision number moved."""
    moved, count = FLOAT.subn(_ulps, arcade_xml)
    assert count > 900 and moved != arcade_xml
    report = assert_xml_equivalent(moved, arcade_xml)
    assert report.numbers > 4000 and 0 < report.worst < 1e-14


#: (id, (old, new, count) of str.replace, what the failure must say)
CHANGES = [
    ("number", ("0.039684191511083815", "0.039684191551083815", 1), "leaf_p0_L1_base] text: number 15"),  # 1e-9
    ("name", ('name="leaf_p0_L1_base/b"', 'name="leaf_p0_L1_base/c"', 1), "text differs beyond its numbers"),
    ("digit-in-name", ('name="leaf_p0_L1_base/b"', 'name="leaf_p0_L2_base/b"', 1), "text differs beyond its"),
    (
        "attribute-order",
        ('size="0.002 0.002 0.002" pos="0.1355 0 0.09"', 'pos="0.1355 0 0.09" size="0.002 0.002 0.002"', 1),
        "attributes",
    ),
    ("attribute-added", ('group="5"/>', 'group="5" rgba="1 0 0 1"/>', 1), "attributes"),
    ("attribute-number", ('pos="0.1355 0 0.09"', 'pos="0.1355 0 0.0900001"', 1), "[leaf_p0_L1_base/b]@pos: number 2"),
    ("list-length", ('pos="0.1355 0 0.09"', 'pos="0.1355 0 0.09 0"', 1), "text differs beyond its numbers"),
    ("record-text", ('"method": "twist"', '"method": "dualquat"', 1), "text differs beyond its numbers"),
    ("element", ("<light ", "<camera ", 1), "worldbody[6]: child 0 is <camera> where <light> was expected"),
]


@pytest.mark.parametrize("edit, message", [pytest.param(e, m, id=i) for i, e, m in CHANGES])
def test_any_other_change_fails_and_is_named(arcade_xml, edit, message):
    changed = arcade_xml.replace(*edit)
    assert changed != arcade_xml
    with pytest.raises(AssertionError, match=re.escape(message)):
        assert_xml_equivalent(changed, arcade_xml)


def test_element_order_and_count_matter():
    a = '<mujoco><body name="a"/><body name="b"/></mujoco>'
    assert compare_xml(a, a).problems == []
    assert "[a]" in compare_xml('<mujoco><body name="b"/><body name="a"/></mujoco>', a).problems[0]
    assert (
        "child 1 is nothing where <body> was expected"
        in compare_xml('<mujoco><body name="a"/></mujoco>', a).problems[0]
    )


def test_plugin_config_lists_compare_their_numbers():
    """The engine-plugin form: numbers as text in ``config value`` lists, one list per attribute."""
    text = '<mujoco><plugin plugin="mjflex.twist"><config key="K" value="{}"/></plugin></mujoco>'
    K = [4306176.908895898, 2.4365597402613397, 0.0, 1e-300]
    expected = text.format(" ".join(map(repr, K)))
    ulp = text.format(" ".join(repr(math.nextafter(k, math.inf)) for k in K))
    assert compare_xml(ulp, expected).problems == []
    # one list: its entries are judged against its largest (1e-14 x 4.3e6 = 4.3e-8), a 1e-6 change of 2.4 is not
    wrong = text.format(" ".join(map(repr, [K[0], K[1] * (1 + 1e-6), *K[2:]])))
    assert "plugin[0]/config[0]@value: number 1 is" in compare_xml(wrong, expected).problems[0]


def test_a_near_zero_entry_is_judged_against_its_list():
    """Cancellation leaves ulps of the list's largest entry where an exact 0 was: tolerated relative to the list."""
    assert compare_text("[4e6, 1e-10]", "[4e6, 0.0]").problems == []  # 1e-10 <= 1e-14 * 4e6
    assert compare_text("[1.0, 1e-10]", "[1.0, 0.0]").problems  # 1e-10 > 1e-14 * 1
    assert compare_text('{"E": 4e6, "R": 0.0040001}', '{"E": 4e6, "R": 0.004}').problems  # scalars stand alone
    assert RTOL * 1e3 < 1e-8 and ATOL_SCALE < RTOL  # still tight: a change of the model's 4-6-digit inputs fails


def test_numbers_are_tokens_not_digits_in_names():
    _, numbers, _ = split_numbers('"leaf_p0_L1" v4.0.0 x-1 -1e-05 [NaN, -Infinity] 3.')
    assert numbers == ["-1e-05", "NaN", "-Infinity", "3."]
    assert compare_text("[NaN, -Infinity]", "[NaN, -Infinity]").problems == []
    assert compare_text("[NaN]", "[1.0]").problems and compare_text("[Infinity]", "[-Infinity]").problems
