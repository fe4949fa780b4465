"""One schema (issue 30): the C library's table of element attributes is the one rulebook of both forms.

* the schema page is the table;
* one rule, one check in C, one message: for each of 34 malformed elements, its plugin instance (MuJoCo's compile
  error) and its text record (mjflex.Flexures) fail with the same text, raised by the C library;
* a check runs once: no Python check of a record's values on the way from add_flexure to Flexures;
* a display-only attribute lives in the table and the drawing only;
* the number grammar, the white space rule and the bounds are one (issue 33 items 10, 15); attach binds the
  element's own sites (item 13);
* converting is lossless for every model of models/ and of the test suite.
"""

import json
import os
import re

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.core import validation
from mjflex.mjcf import schema
from mjflex.mjcf.config import attached_names, config_from_record, record_from_config
from mjflex.native import library
from mjflex.runtime.files import same_record
from tests import native_cases, stop_models
from tests.models import K_DEMO, hinge_chain_spec, two_body_spec
from tests.plugin_models import MODELS, planar_spec, polynomial_terms
from tests.spine import spine_spec
from tests.test_stop_damping import damped_spec
from tests.test_stops import _random_state
from tests.warp_models import features_xml

ROOT = os.path.join(os.path.dirname(__file__), "..")
PAGE = os.path.join(ROOT, "docs", "reference", "mjcf_schema.md")
START, END = "do not edit by hand -->\n", "<!-- end of the schema table -->\n"


def test_the_schema_page_is_the_table():
    """docs/reference/mjcf_schema.md shows the C library's table (python scripts/schema_page.py writes it)."""
    with open(PAGE) as f:
        page = f.read()
    assert page.split(START)[1].split(END)[0] == schema.schema_page(), "run: python scripts/schema_page.py"
    rows = schema.schema_page().splitlines()[2:]
    assert [r.split(" | ")[0].strip("| `") for r in rows] == [a.key for a in schema.attributes()]
    assert len(rows) == 20 and all(a.meaning and a.rules and a.shape for a in schema.attributes())


def test_the_record_fields_are_the_tables_json_keys_in_its_order():
    """FlexureRecord's attributes (positional order of 1.0.0 kept) and the record's keys come from the table."""
    assert schema.record_fields()[:12] == ("method", "K", "B", "enabled", "viscous", "strain_per_radian", "source",
                                           "terms", "order", "site", "strain_scale", "stops")  # fmt: skip
    assert schema.keys() == ("mjflex", *schema.record_fields())
    record = schema.FlexureRecord("e", "twist", np.eye(6), None, False)
    assert record.enabled is False and record.viscous is True and record.order == 2 and record.stops is None
    with pytest.raises(TypeError, match=r"'stiffness' is not an attribute of a record"):
        schema.FlexureRecord("e", K=np.eye(6), stiffness=1.0)


# ------------------------------------------------------------------ one rulebook

BASE = {"site_a": "e/a", "site_b": "e/b", "K": "1 2 3 1000 2000 3000"}
K6 = [1.0, 2.0, 3.0, 1000.0, 2000.0, 3000.0]
ASYM = np.diag(K6)
ASYM[0, 1] = 0.5
INDEF = np.diag(K6)
INDEF[0, 3] = INDEF[3, 0] = 100.0
TERM = {"order": 4, "terms": {"exponents": [[0, 0, 4, 0, 0, 0]], "coefficients": [1.0]}}
STOP = "0.1 inf inf inf inf inf"
N5 = [None] * 5


def _flat(M):
    return " ".join(repr(float(v)) for v in np.ravel(M))


# rule -> (plugin config changes, record JSON changes, the C message it gives, after the form's head)
RULES = {
    "K missing": ({"K": None}, {"K": None}, r"^K is missing: give 6 numbers"),
    "K of 5 numbers": ({"K": "1 2 3 4 5"}, {"K": [1, 2, 3, 4, 5]}, r"^K has 5 numbers. Give 6 numbers"),
    "K not finite": ({"K": "1 2 3 inf 5 6"}, {"K": [1, 2, 3, 1e999, 5, 6]}, r"^K\[3, 3\] = inf is not finite"),
    "K beyond 1e280": ({"K": "1 2 3 1e300 5 6"}, {"K": [1, 2, 3, 1e300, 5, 6]}, r"^K\[3, 3\] = 1e\+300 is beyond"),
    "K not symmetric": ({"K": _flat(ASYM)}, {"K": ASYM.tolist()}, r"^K is not symmetric: K\[0, 1\] = 0.5"),
    "K indefinite": ({"K": _flat(INDEF)}, {"K": INDEF.tolist()}, r"^K is not positive semi-definite"),
    "B of another size": ({"B": "1 2 3"}, {"B": [1, 2, 3]}, r"^B has 3 numbers. Give 6 or 36 numbers, as K"),
    "B indefinite": ({"B": "1 -2 3 4 5 6"}, {"B": [1, -2, 3, 4, 5, 6]}, r"^B is not positive semi-definite"),
    "method misspelt": ({"method": "twst"}, {"method": "twst"}, r"^unknown method 'twst'. Use method \"twist\""),
    "odd dualquat order": (
        {"method": "dualquat", "order": "4", "exponents": "0 0 0 0 0 3 0 0", "coefficients": "1"},
        {"method": "dualquat", "order": 4, "terms": {"exponents": [[0, 0, 0, 0, 0, 3, 0, 0]], "coefficients": [1]}},
        r"^exponents row 0 has odd degree 3",
    ),
    "exponents not in rows": (
        {"order": "4", "exponents": "0 0 4 0 0", "coefficients": "1"},
        {"order": 4, "terms": {"exponents": [[0, 0, 4, 0, 0]], "coefficients": [1]}},
        r"^exponents has 5 integers, not a multiple of 6",
    ),
    "a coefficient too few": (
        {"order": "4", "exponents": "0 0 4 0 0 0 4 0 0 0 0 0", "coefficients": "1"},
        {"order": 4, "terms": {"exponents": [[0, 0, 4, 0, 0, 0], [4, 0, 0, 0, 0, 0]], "coefficients": [1]}},
        r"^2 rows of exponents but 1 coefficients",
    ),
    "a linear term": (
        {"order": "4", "exponents": "0 0 1 0 0 0", "coefficients": "1"},
        {"order": 4, "terms": {"exponents": [[0, 0, 1, 0, 0, 0]], "coefficients": [1]}},
        r"^exponents row 0 is a linear term",
    ),
    "a term above the order": (
        {"exponents": "0 0 3 0 0 0", "coefficients": "1"},
        {"terms": {"exponents": [[0, 0, 3, 0, 0, 0]], "coefficients": [1]}},
        r"^exponents row 0 has degree 3, above order 2",
    ),
    "an exponent beyond 16": (
        {"order": "20", "exponents": "0 0 17 0 0 0", "coefficients": "1"},
        {"order": 20, "terms": {"exponents": [[0, 0, 17, 0, 0, 0]], "coefficients": [1]}},
        r"^exponents has 17 \(number 2\): give integers in \[0, 16\]",
    ),
    "a repeated term": (
        {"order": "4", "exponents": "0 0 4 0 0 0 0 0 4 0 0 0", "coefficients": "1 2"},
        {"order": 4, "terms": {"exponents": [[0, 0, 4, 0, 0, 0]] * 2, "coefficients": [1, 2]}},
        r"^exponents row 1 repeats row 0",
    ),
    "order beyond 128": ({"order": "130"}, {"order": 130}, r"^order must be one integer from 2 to 128; got '130'"),
    "negative strain": ({"strain_per_radian": "-1"}, {"strain_per_radian": -1}, r"^strain_per_radian must be a fin"),
    "zero strain scale": ({"strain_scale": "0"}, {"strain_scale": 0}, r"^strain_scale must be a finite number > 0"),
    "a stop in degrees": (
        {"stop_upper": "90 inf inf inf inf inf"},
        {"stops": {"upper": [90, *N5]}},
        r"^stop_upper of rx is 90 rad, beyond pi",
    ),
    "lower above upper": (
        {"stop_lower": "0.2 -inf -inf -inf -inf -inf", "stop_upper": STOP},
        {"stops": {"lower": [0.2, *N5], "upper": [0.1, *N5]}},
        r"^stop_lower of rx \(0.2\) is above its stop_upper \(0.1\)",
    ),
    "stiffness without a stop": (
        {"stop_stiffness": "3"},
        {"stops": {"stiffness": 3}},
        r"^stop_stiffness is given but there is no stop",
    ),
    "a derived stiffness beyond 1e280": (
        {"K": "1e279 2 3 4 5 6", "stop_upper": STOP},
        {"K": [1e279, 2, 3, 4, 5, 6], "stops": {"upper": [0.1, *N5]}},
        r"^the stop on rx would derive its stiffness 100 x K\[0, 0\] = 1e\+281, beyond 1e\+280",
    ),
    "a stop without stiffness": (
        {"K": "0 2 3 4 5 6", "stop_upper": STOP},
        {"K": [0, 2, 3, 4, 5, 6], "stops": {"upper": [0.1, *N5]}},
        r"^the stop on rx needs a stiffness: K\[0, 0\] is 0",
    ),
    "negative stop damping": (
        {"stop_upper": STOP, "stop_damping": "-1"},
        {"stops": {"upper": [0.1, *N5], "damping": -1}},
        r"^stop_damping of every coordinate is -1; give a finite number >= 0",
    ),
    "infinite stop damping": (
        {"stop_upper": STOP, "stop_damping": "0 0 inf 0 0 0"},
        {"stops": {"upper": [0.1, *N5], "damping": [0, 0, 1e999, 0, 0, 0]}},
        r"^stop_damping of rz is inf; give a finite number >= 0",
    ),
    "stop damping of 2 numbers": (
        {"stop_upper": STOP, "stop_damping": "1 2"},
        {"stops": {"upper": [0.1, *N5], "damping": [1, 2]}},
        r"^stop_damping has 2 numbers; give 1 \(every coordinate\) or 6 \(one per coordinate \[rx ry rz x y z\]\)",
    ),
    "stop damping without a stop": (
        {"stop_damping": "3"},
        {"stops": {"damping": 3}},
        r"^stop_damping is given but there is no stop",
    ),
    "a rest quaternion that is no rotation": (
        {"rest_quat": "1 0 0 0.1"},
        {"rest": {"quat": [1, 0, 0, 0.1]}},
        r"^rest_quat \(1 0 0 0.1\) has norm 1.00498756, so it is not a rotation",
    ),
    "a rest quaternion of 3 numbers": ({"rest_quat": "1 0 0"}, {"rest": {"quat": [1, 0, 0]}}, r"^rest_quat has 3 numb"),
    "an infinite rest quaternion": (
        {"rest_quat": "inf 0 0 0"},
        {"rest": {"quat": [1e999, 0, 0, 0]}},
        r"^rest_quat has inf \(number 0\); give finite numbers",
    ),
    "a rest position of 2 numbers": ({"rest_pos": "0 0"}, {"rest": {"pos": [0, 0]}}, r"^rest_pos has 2 numbers"),
    "a rest position beyond 1e10 m": (
        {"rest_pos": "0 -1e280 0"},
        {"rest": {"pos": [0, -1e280, 0]}},
        r"^rest_pos has -1e\+280 \(number 1\); give finite numbers \(\|x\| <= 1e\+10\)",
    ),
    "an infinite rest position": (
        {"rest_pos": "0 -inf 0"},
        {"rest": {"pos": [0, -1e999, 0]}},
        r"^rest_pos has -inf \(number 1\); give finite numbers",
    ),
}


def _model_xml(config=None, record=None):
    """Two free boxes and element 'e' between sites e/a and e/b, as a plugin instance or a text record."""
    rows = "".join(f'<config key="{k}" value="{v}"/>' for k, v in (config or {}).items())
    plugin = f'<extension><plugin plugin="mjflex.flexure"><instance name="e">{rows}</instance></plugin></extension>'
    text = record and f"<custom><text name=\"mjflex:e\" data='{_json(record)}'/></custom>"
    return f"""<mujoco>{plugin if config else ""}<option gravity="0 0 0"/><worldbody>
      <body name="A"><freejoint/><geom size="0.05"/><site name="e/a" pos="0.05 0 0"/></body>
      <body name="B" pos="0.1 0 0"><freejoint/><geom size="0.05"/><site name="e/b" pos="-0.05 0 0"/></body>
      </worldbody><contact><exclude body1="A" body2="B"/></contact>{text or ""}</mujoco>"""


def _json(record):
    """A record's JSON text; an infinite number written as 1e999, a JSON number beyond the doubles."""
    return json.dumps(record).replace("Infinity", "1e999")


def _message(text, head):
    """The message after the form's head (MuJoCo's compile error repeats it, after a line of its own)."""
    line = next(s for s in text.splitlines() if head in s)
    return line.split(head, 1)[1]


def _canonical(message):
    """A message with the record's keys spelt as the plugin's (stops.lower -> stop_lower, ...)."""
    for a in schema.attributes():
        if a.json and a.json != a.key:
            message = re.sub(rf"\b{re.escape(a.json)}\b", a.key, message)
    return message


@pytest.mark.parametrize("rule", list(RULES))
def test_one_rule_one_check_in_c_one_message_in_both_forms(rule):
    """The plugin instance fails to compile and the text record fails in Flexures, both with the same text from
    the same C check (the record form's error is raised by the native library, not by Python); so does Python's
    reading of the plugin configuration."""
    changes, record_changes, expected = RULES[rule]
    config = {k: v for k, v in {**BASE, **changes}.items() if v is not None}
    record = {k: v for k, v in {"mjflex": 1, "K": K6, **record_changes}.items() if v is not None}
    with pytest.raises(ValueError) as compiled:
        mujoco.MjModel.from_xml_string(_model_xml(config=config))
    plugin = _message(str(compiled.value), "(plugin instance of mjflex.flexure): ")
    model = mujoco.MjModel.from_xml_string(_model_xml(record=record))
    with pytest.raises(mjflex.ModelError) as read:
        mjflex.Flexures(model)
    in_record = _message(str(read.value), "flexure 'e': ")
    with pytest.raises(ValueError) as parsed:
        schema.parse_text("e", _json(record))
    assert re.search(expected, plugin), plugin
    assert _canonical(in_record) == plugin == _canonical(_message(str(parsed.value), "flexure 'e': "))
    assert parsed.traceback[-1].path.name == "library.py"  # raised where the C library's message is read
    with pytest.raises(ValueError) as python:
        record_from_config("e", config)
    assert _message(str(python.value), "(plugin instance of mjflex.flexure): ") == plugin


def test_twenty_rules_at_least():
    assert len(RULES) >= 20 and len({r[2] for r in RULES.values()}) == len(RULES)


def test_a_check_runs_once_from_add_flexure_to_flexures(monkeypatch):
    """No Python check of K on the way (the C library checks it once per reading), and one C reading each at
    add_flexure and at Flexures (1.0.0 checked K's positive semi-definiteness up to five times on this path)."""
    calls = {"parse": 0, "table": 0}
    parse, table = library.parse_values, library.read_table

    def counted(name, function):
        def call(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return call

    def refused(*args, **kwargs):
        raise AssertionError("a Python check of a matrix ran")

    monkeypatch.setattr(validation, "check_psd_matrix", refused)
    monkeypatch.setattr(library, "parse_values", counted("parse", parse))
    monkeypatch.setattr(library, "read_table", counted("table", table))
    for kind in ("plugin", "record"):
        spec = two_body_spec(kind=kind, B=0.01 * K_DEMO, terms=polynomial_terms("twist"))
        assert calls == {"parse": 1, "table": 0}
        flex = mjflex.Flexures(spec.compile())
        assert calls == {"parse": 1, "table": 1} and flex.records[0].terms is not None
        calls.update(parse=0, table=0)


def test_a_display_attribute_lives_in_the_table_and_the_drawing_only():
    """strain_scale (display only) is named in the C table, the engine plugin's drawing and mjflex's renderer,
    and by ARCADE, which sets it; nowhere else in the package (1.0.0: 11 files)."""
    package = os.path.join(ROOT, "mjflex")
    found = set()
    for folder, _, files in os.walk(package):
        for name in files:
            if name.endswith((".py", ".c", ".h")):
                with open(os.path.join(folder, name)) as f:
                    if "strain_scale" in f.read():
                        found.add(os.path.relpath(os.path.join(folder, name), package))
    assert found == {"native/schema.c", "native/plugin.c", "app/render.py", "app/arcade.py"}, found


# ------------------------------------------------------------------ issue 33: one grammar, one bound, attach


def test_white_space_around_a_value_is_one_rule_in_both_forms():
    """Issue 33 item 10: 'twist ' is the method twist in both forms (1.0.0: the plugin refused it, Python's
    reading of the same configuration took it); a word with white space inside is refused by both."""
    config = {**BASE, "method": " dualquat\t"}
    model = mujoco.MjModel.from_xml_string(_model_xml(config=config))
    assert mjflex.Flexures(model).methods == ("dualquat",)
    record = {"mjflex": 1, "K": K6, "method": "dualquat "}
    assert mjflex.Flexures(mujoco.MjModel.from_xml_string(_model_xml(record=record))).methods == ("dualquat",)
    with pytest.raises(ValueError, match=r"unknown method 'dual quat'"):
        mujoco.MjModel.from_xml_string(_model_xml(config={**BASE, "method": "dual quat"}))
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': unknown method 'dual quat'"):
        mjflex.Flexures(mujoco.MjModel.from_xml_string(_model_xml(record={**record, "method": "dual quat"})))


def test_hexadecimal_numbers_run_in_mujoco_and_in_flexures_alike():
    """Issue 33 item 15: numbers are what C's strtod reads, for MuJoCo's compile and for Flexures (1.0.0:
    Flexures refused 0x1p0 with a message that did not name the element)."""
    model = mujoco.MjModel.from_xml_string(_model_xml(config={**BASE, "K": "0x1p0 2 3 0x1.f4p9 2000 3000"}))
    record = mjflex.Flexures(model).records[0]
    assert record.K[0, 0] == 1.0 and record.K[3, 3] == 1000.0
    assert config_from_record(record, "e/a", "e/b")["K"] == "1.0 2.0 3.0 1000.0 2000.0 3000.0"


def test_a_source_number_beyond_a_double_is_refused_in_both_forms():
    """A JSON number of the source that no double holds (1e400) is refused, as NaN is: read back, it would be
    infinity, which JSON cannot write (1.0.0 took it in a plugin configuration, then could not write the record)."""
    with pytest.raises(ValueError, match=r"flexure 'e' .*: source must be one JSON object.*numbers within doubles"):
        mujoco.MjModel.from_xml_string(_model_xml(config={**BASE, "source": "{&quot;a&quot;: 1e400}"}))
    model = mujoco.MjModel.from_xml_string(_model_xml(record={"mjflex": 1, "K": K6, "source": {"a": float("inf")}}))
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': source must be one JSON object"):
        mjflex.Flexures(model)


def test_the_derived_stop_stiffness_has_the_bound_of_a_given_one():
    """Issue 33 item 15: 100 K_ii beyond 1e280 is refused in C, naming the element (1.0.0: C took it, up to
    1e282, and only mjflex.warp refused it); just within, it is the stiffness C lays out."""
    config = {**BASE, "K": "1e278 2 3 4 5 6", "stop_upper": STOP}
    model = mujoco.MjModel.from_xml_string(_model_xml(config=config))
    assert mjflex.Flexures(model).element_table.elements[0]["stop_k"][0] == 1e280
    stops = mjflex.Stops(upper=[0.1, *N5])
    assert stops.stiffness_for(np.diag([1e278, 1, 1, 1, 1, 1]))[0] == 1e280
    with pytest.raises(ValueError, match=r"would derive its stiffness 100 x K\[0, 0\] = 1e\+281, beyond 1e\+280"):
        stops.stiffness_for(np.diag([1e279, 1, 1, 1, 1, 1]))


def _child(prefix=""):
    """A spec with bodies A, B (free) and element e between its sites a and b, as a plugin instance."""
    spec = mujoco.MjSpec()
    for name, x in (("A", 0.0), ("B", 0.1)):
        body = spec.worldbody.add_body(name=name, pos=[x, 0, 1])
        body.add_freejoint()
        body.add_geom(size=[0.02, 0, 0], contype=0, conaffinity=0)
        body.add_site(name="a" if name == "A" else "b", pos=[0.05 - x, 0, 0])
    spec.activate_plugin("mjflex.flexure")
    plugin = spec.add_plugin(name="e", plugin_name="mjflex.flexure", active=True)
    plugin.config = {"site_a": "a", "site_b": "b", "K": "1 1 1 1000 1000 1000", "site": "a"}
    return spec


def _parent(sites):
    """A spec with a free body P whose sites ``sites`` sit where the child's site a does (world 0.05 0 1): an
    element bound to one of them instead compiles, silently joining P."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="P", pos=[0, 1, 0])
    body.add_freejoint()
    body.add_geom(size=[0.02, 0, 0], contype=0, conaffinity=0)
    for site in sites:
        body.add_site(name=site, pos=[0.05, -1, 1])
    return spec


def _bound(model, flex):
    names = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        for b in flex.element_table.elements[0][["body_a", "body_b"]]
    ]
    return names, flex.element_table.sites[0]


def _attach_as_1_0(parent, child, prefix, frame):
    """``mjflex.attach`` as mjflex 1.0 did it: the instances added back with their configurations as the child
    wrote them (files saved then hold these)."""
    kept = [(p.name, dict(p.config)) for p in child.plugins]
    parent.attach(child, prefix=prefix, frame=frame)
    parent.activate_plugin("mjflex.flexure")
    for name, config in kept:
        parent.add_plugin(name=prefix + name, plugin_name="mjflex.flexure", active=True).config = config


def test_attach_writes_the_attached_site_names():
    """mjflex.attach renames an instance's sites with the sites (the frame site too): the file names the sites the
    element joins, and a parent's own site a is not l/e's site a."""
    parent = _parent(["a", "b"])
    mjflex.attach(parent, _child(), prefix="l/", frame=parent.worldbody.add_frame())
    config = {k: v for k, v in parent.plugin("l/e").config.items() if k in ("site_a", "site_b", "site")}
    assert config == {"site_a": "l/a", "site_b": "l/b", "site": "l/a"}
    model = parent.compile()
    assert _bound(model, mjflex.Flexures(model)) == (["l/A", "l/B"], ("l/a", "l/b"))


def test_a_1_0_attached_configuration_binds_the_elements_own_sites_not_a_parents_namesake():
    """Issue 33 item 13, for files that mjflex 1.0 attached (configurations as the child wrote them): l/e's site_a
    "a" is l/a, not the parent's own site a (1.0.0 joined the parent's body to l/B, silently), in C (the plugin's
    init, and the frame site "site") and in Python (attached_names)."""
    parent = _parent(["a"])
    _attach_as_1_0(parent, _child(), "l/", parent.worldbody.add_frame())
    assert parent.plugin("l/e").config["site_a"] == "a"
    model = parent.compile()
    flex = mjflex.Flexures(model)
    assert _bound(model, flex) == (["l/A", "l/B"], ("l/a", "l/b"))
    assert attached_names(("a", "b"), "l/e", ["a", "l/a", "l/b"]) == ("l/a", "l/b")
    assert attached_names(("a", "b"), "e", ["a", "b", "l/a", "l/b"]) == ("a", "b")  # no prefix: the names


def test_nested_prefixes_bind_the_innermost_site():
    """l/r/e's site a is l/r/a, not l/a (a site of the middle spec), in C and in Python, attached now or by 1.0."""
    for attach in (lambda parent, child, prefix, frame: mjflex.attach(parent, child, prefix=prefix, frame=frame),
                   _attach_as_1_0):  # fmt: skip
        middle = _parent(["a"])
        attach(middle, _child(), "r/", middle.worldbody.add_frame())
        top = _parent([])
        attach(top, middle, "l/", top.worldbody.add_frame())
        model = top.compile()
        flex = mjflex.Flexures(model)
        assert flex.names == ("l/r/e",)
        assert _bound(model, flex) == (["l/r/A", "l/r/B"], ("l/r/a", "l/r/b"))
    assert attached_names(("a", "b"), "l/r/e", ["l/a", "l/b", "l/r/a", "l/r/b", "a"]) == ("l/r/a", "l/r/b")


def test_a_name_that_ends_like_an_affix_binds_its_own_sites():
    """Element j1 joins s0 and t1, not t11 (j1 = "j" + suffix "1" would make t1 read t11), when the model has
    both: a chain of 13 links, in C and in Python; an element's sites share one affix (e1: a, b; not b1 alone)."""
    model = mujoco.MjModel.from_xml_string(native_cases.chain_xml(13))
    flex = mjflex.Flexures(model)
    sites = dict(zip(flex.names, flex.element_table.sites, strict=True))
    assert sites["j1"] == ("s0", "t1") and sites["j11"] == ("s10", "t11")
    table = flex.element_table.elements
    for k, name in enumerate(flex.names):
        a, b = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, s) for s in sites[name])
        assert (table[k]["site_a"], table[k]["site_b"]) == (a, b), name
    assert attached_names(("a", "b"), "e1", ["a", "b", "b1"]) == ("a", "b")
    assert attached_names(("a", "b"), "e1", ["a1", "b", "b1"]) == ("a1", "b1")  # not a1 with b
    assert attached_names(("a", "b"), "e1", ["a1", "b"]) is None
    assert attached_names(("a", "b", ""), "x/e", ["x/a", "x/b"]) == ("x/a", "x/b", "")  # no frame site: ""


# ------------------------------------------------------------------ lossless conversion of every model


def _tricky():
    """Every attribute of the table, each number one that text could lose (the rest quaternion a rotation of norm 1
    to the last bit or not, but within the tolerance)."""
    record = schema.FlexureRecord(
        "link", "twist", np.diag([0.1 + 0.2, 1 / 3, 2.0, 1e6, 5e-300, 3e6]), np.diag([1e-7] * 6), False, False,
        1 / 7, {"E": 7e10, "note": "Π ≈ 3.14", "n": [1, 2**70]}, polynomial_terms("twist"), 4, "link/a", 0.0123,
        mjflex.Stops([-0.1, None, None, -1e-3, None, None], [0.2] * 6, stiffness=[1.0, 2, 3, 4, 5, 6], damping=0.5),
        ((0.001, 1 / 3, -0.002), (np.cos(0.1), 0.0, np.sin(0.1) / 3, np.sin(0.1) * np.sqrt(8) / 3)),
    )  # fmt: skip
    return record


def test_every_attribute_converts_losslessly_between_the_forms():
    record = _tricky()
    config = config_from_record(record, "link/a", "link/b")
    assert set(config) == {a.key for a in schema.attributes()}  # every attribute given
    back = record_from_config("link", config)
    again = schema.parse_text("link", back.to_text())
    assert same_record(record, back) and same_record(record, again) and again.to_text() == record.to_text()
    assert again.stops.damping == 0.5 and again.rest == record.rest and again.rest[0][1] == 1 / 3
    assert np.array_equal(again.terms.exponents, record.terms.exponents) and again.source["n"][1] == 2**70


def _suite_models():
    """Specs of the test suite's models with elements (text records), by name."""
    return {
        "two_body dualquat B": lambda: two_body_spec(method="dualquat", B=0.02 * K_DEMO),
        "two_body terms": lambda: two_body_spec(terms=polynomial_terms("twist"), B=0.01 * K_DEMO),
        "hinge chain": lambda: hinge_chain_spec(n=4),
        "planar with stops": lambda: planar_spec(
            stops=mjflex.Stops(lower=[-1.0, None, -0.05], upper=[1.0, 0.08, None])
        ),
        "spine with a disc": _spine_with_a_disc,
        "warp features with stops": lambda: mujoco.MjSpec.from_string(features_xml("record", stops=True)),
        "tricky": lambda: _tricky_spec(),
        "damped stops and rest poses": _damped_spec,
        "a link into a damped stop": lambda: stop_models.link_spec("damped"),
        "a finger preloaded by a rest pose": lambda: stop_models.finger_spec("rest"),
    }


def _damped_spec():
    """tests/test_stop_damping's four elements (damped stops, rest poses) placed around a random state, as records."""
    qpos = _random_state(damped_spec().compile(), np.random.default_rng(3))
    return damped_spec(qpos, kind="record", seed=3)


def _spine_with_a_disc():
    """The spine whose L3 joints a disc replaced (make_compliant: a record with a frame site and its sources)."""
    spec = spine_spec()
    mjflex.make_compliant(spec, "L3", [50.0, 50.0, 30.0, 2e5, 2e5, 5e5], replace_joints=True, kind="record")
    return spec


def _tricky_spec():
    spec = two_body_spec(timestep=1e-4)
    spec.text("mjflex:link").data = _tricky().to_text()
    return spec


FILES = sorted(f for f in os.listdir(MODELS) if f.endswith(".xml"))


@pytest.mark.parametrize("case", FILES + list(_suite_models()))
def test_convert_round_trips_every_model_bit_for_bit(case, tmp_path):
    """record -> plugin -> record -> plugin (python -m mjflex convert): the same records, every number bit for bit,
    and the files of the second round the same text as those of the first."""
    if case in FILES:
        source = os.path.join(MODELS, case)
    else:
        source = str(tmp_path / "source.xml")
        with open(source, "w") as f:
            f.write(_suite_models()[case]().to_xml())
    first = mjflex.Flexures(mujoco.MjModel.from_xml_path(source))
    if not first.names:  # the rigid twin of ARCADE: nothing to convert
        assert case == "arcade_rigid.xml" and mjflex.convert_file(source, str(tmp_path / "r.xml"), to="record") == []
        return
    paths = [str(tmp_path / f"{i}.xml") for i in range(4)]
    kinds = ["record", "plugin"] if first.kinds[0] == "plugin" else ["plugin", "record"]
    previous = source
    for path, kind in zip(paths, kinds * 2, strict=True):
        mjflex.convert_file(previous, path, to=kind)
        flex = mjflex.Flexures(mujoco.MjModel.from_xml_path(path))
        assert flex.kinds == (kind,) * len(first.names)
        for a, b in zip(first.records, flex.records, strict=True):
            assert same_record(a, b), (case, a.name)
        previous = path
    for one, two in ((paths[0], paths[2]), (paths[1], paths[3])):
        with open(one) as f, open(two) as g:
            assert f.read() == g.read()


def test_every_configuration_c_accepts_reads_back_losslessly_and_every_refusal_names_the_element():
    """Hostile values of the native fuzzer (scripts/fuzz_native.py) in 1 to 3 attributes: what C accepts, Python
    reads and writes back in both forms to the same text (1.0.0: 0x1p0 and a source holding 1e400 broke the
    round trip); what C refuses, it refuses naming the element."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("fuzz_native", os.path.join(ROOT, "scripts", "fuzz_native.py"))
    fuzz = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fuzz)
    keys, accepted = [a.key for a in schema.attributes() if a.key not in ("site_a", "site_b")], 0
    for i in range(600):
        rng = np.random.default_rng([30, i])
        config = {**BASE, "stop_upper": STOP}
        method = str(rng.choice(["twist", "dualquat"]))
        for _ in range(int(rng.integers(1, 4))):
            key = str(rng.choice(keys))
            config[key] = fuzz.hostile_value(rng, key, method)
        try:
            record = record_from_config("e", config)
        except ValueError as exc:
            assert "mjflex: flexure 'e' (plugin instance of mjflex.flexure): " in str(exc), (i, config)
            continue
        accepted += 1
        again = record_from_config("e", config_from_record(record, "e/a", "e/b"))
        assert record.to_text() == again.to_text() == schema.parse_text("e", again.to_text()).to_text(), (i, config)
    assert 50 < accepted < 550  # both outcomes are exercised
