"""Every ModelError is raised by a deliberately broken model file, with a message that names the element and the fix."""

import json

import mujoco
import numpy as np
import pytest

import mjflex

K6 = [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0]

TEMPLATE = """
<mujoco model="broken">
  <compiler angle="radian"/>
  <worldbody>
    <body name="A" pos="0 0 0">
      <freejoint/>
      <geom type="box" size=".05 .01 .01"/>
      <site name="{site_a}" pos="0.05 0 0"/>
      {extra_a}
    </body>
    <body name="B" pos="0.1 0 0">
      <freejoint/>
      <geom type="box" size=".05 .01 .01"/>
      <site name="{site_b}" pos="{pos_b}" {quat_b}/>
    </body>
  </worldbody>
  <contact>
    <exclude body1="A" body2="B"/>
  </contact>
  <custom>
    <text name="mjflex:e" data='{data}'/>
  </custom>
</mujoco>
"""


def _model(*, site_a="e/a", site_b="e/b", pos_b="-0.05 0 0", quat_b="", extra_a="", data=None, **record):
    payload = {"mjflex": 1, "method": "twist", "K": K6}
    payload.update(record)
    text = json.dumps(payload) if data is None else data
    xml = TEMPLATE.format(site_a=site_a, site_b=site_b, pos_b=pos_b, quat_b=quat_b, extra_a=extra_a, data=text)
    return mujoco.MjModel.from_xml_string(xml)


def test_valid_template_loads():
    flex = mjflex.Flexures(_model())
    assert flex.names == ("e",)


def test_missing_site_suggests_the_close_name():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': site 'e/b' not found\..*Did you mean 'e_b'\?"):
        mjflex.Flexures(_model(site_b="e_b"))


def test_misnamed_site_without_close_match():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': site 'e/a' not found\. Add <site name=\"e/a\"/>"):
        mjflex.Flexures(_model(site_a="hinge_left"))


def test_both_frames_on_one_body():
    model = _model(site_b="other", extra_a='<site name="e/b" pos="0.05 0 0"/>')
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': both sites are on body 'A'\. Put site a on one body"):
        mjflex.Flexures(model)


def test_frames_not_coincident_at_qpos0():
    with pytest.raises(
        mjflex.ModelError, match=r"flexure 'e': sites 'e/a' and 'e/b' are 0\.01 m apart.*same world pose"
    ):
        mjflex.Flexures(_model(pos_b="-0.04 0 0"))


def test_frames_not_aligned_at_qpos0():
    with pytest.raises(mjflex.ModelError, match=r"are 0 m apart and 0\.2 rad apart at qpos0"):
        mjflex.Flexures(_model(quat_b='axisangle="0 0 1 0.2"'))


def test_non_symmetric_K():
    K = np.diag(K6)
    K[0, 4] = 2.0
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*K is not symmetric: K\[0, 4\] = 2.*Fix K"):
        mjflex.Flexures(_model(K=K.tolist()))


def test_indefinite_K():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': K is not positive semi-definite: .*eigenvalue .* is -1"):
        mjflex.Flexures(_model(K=[1.0, -1.0, 1.0, 1.0, 1.0, 1.0]))


def test_indefinite_B():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*B is not positive semi-definite"):
        mjflex.Flexures(_model(B=[0.1, 0.1, -0.1, 0.0, 0.0, 0.0]))


def test_K_with_wrong_shape():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': K has 4 numbers. Give 6 numbers \(the diagonal\) or 36"):
        mjflex.Flexures(_model(K=[1.0, 2.0, 3.0, 4.0]))


def test_B_shape_must_match_K():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': B has 9 numbers. Give 6 or 36 numbers, as K"):
        mjflex.Flexures(_model(B=np.eye(3).tolist()))


def test_non_finite_K():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': .*\"K\"\[5\] is NaN, which is not a JSON number"):
        mjflex.Flexures(_model(data='{"mjflex": 1, "K": [1, 1, 1, 1, 1, NaN]}'))


def test_unknown_method():
    with pytest.raises(
        mjflex.ModelError, match=r"flexure 'e': .*unknown method 'quaternion'. Use method \"twist\" or \"dualquat\""
    ):
        mjflex.Flexures(_model(method="quaternion"))


def test_invalid_json():
    with pytest.raises(mjflex.ModelError, match=r"text record 'mjflex:e' is malformed: its data is not valid JSON"):
        mjflex.Flexures(_model(data='{"mjflex": 1, "K": [1, 2'))


def test_unknown_key():
    with pytest.raises(mjflex.ModelError, match=r"unknown key\(s\) \['stiffness'\]; the allowed keys are"):
        mjflex.Flexures(_model(data='{"mjflex": 1, "stiffness": [1, 1, 1, 1, 1, 1]}'))


def test_missing_K():
    with pytest.raises(mjflex.ModelError, match=r"flexure 'e': K is missing"):
        mjflex.Flexures(_model(data='{"mjflex": 1, "method": "twist"}'))


def test_wrong_schema_version():
    with pytest.raises(mjflex.ModelError, match=r"\"mjflex\" must be the schema version 1; got 2"):
        mjflex.Flexures(_model(data='{"mjflex": 2, "K": [1, 1, 1, 1, 1, 1]}'))


def test_bad_switch_value():
    with pytest.raises(mjflex.ModelError, match=r"\"enabled\" must be true or false; got 'yes'"):
        mjflex.Flexures(_model(enabled="yes"))


def test_add_flexure_argument_errors():
    spec = mujoco.MjSpec()
    for name in "AB":
        b = spec.worldbody.add_body(name=name)
        b.add_freejoint()
        b.add_geom(size=[0.1, 0, 0])
    with pytest.raises(ValueError, match=r"body_b 'C' is not a body of the spec"):
        mjflex.add_flexure(spec, "e", "A", "C", pos=[0, 0, 0], K=K6)
    with pytest.raises(ValueError, match=r"body_a and body_b are the same body"):
        mjflex.add_flexure(spec, "e", "A", "A", pos=[0, 0, 0], K=K6)
    with pytest.raises(ValueError, match=r"flexure 'e': K is not positive semi-definite"):
        mjflex.add_flexure(spec, "e", "A", "B", pos=[0, 0, 0], K=[1, 1, 1, 1, 1, -1])
    with pytest.raises(ValueError, match=r"quat = \[0.0, 0.0, 0.0, 0.0\] is not a rotation"):
        mjflex.add_flexure(spec, "e", "A", "B", pos=[0, 0, 0], quat=[0, 0, 0, 0], K=K6)
    with pytest.raises(ValueError, match=r"flexure 'e': unknown method 'screw'. Use method \"twist\" or \"dualquat\""):
        mjflex.add_flexure(spec, "e", "A", "B", pos=[0, 0, 0], K=K6, method="screw")
    mjflex.add_flexure(spec, "e", "A", "B", pos=[0, 0, 0], K=K6)
    with pytest.raises(ValueError, match=r"flexure 'e' already exists"):
        mjflex.add_flexure(spec, "e", "A", "B", pos=[0, 0, 0], K=K6)
