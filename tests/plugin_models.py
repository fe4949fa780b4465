"""Plugin-element and text-record versions of the test models (mjflex.mjcf.convert on copies of their specs)."""

import os

import mujoco
import numpy as np

import mjflex
from mjflex.mjcf.convert import copy_spec, plugins_to_records, records_to_plugins
from tests.models import B_DEMO, K_DEMO

MODELS = os.path.join(os.path.dirname(__file__), "..", "models")


BAD_STATE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def assert_not_diverged(data, what):
    """A run compared bit for bit must not have diverged: after MuJoCo's auto-reset both sides would only agree on
    the reset state (a diverged run must never look like a result)."""
    bad = {str(w).split(".")[-1]: data.warning[w].number for w in BAD_STATE if data.warning[w].number}
    assert not bad, f"{what} diverged (MuJoCo's warnings {bad}): compare a run that stays finite"


def as_records(spec):
    """A copy of ``spec`` with its mjflex.flexure instances as text records."""
    copy = copy_spec(spec)
    plugins_to_records(copy)
    return copy


def as_plugins(spec, method=None):
    """A copy of ``spec`` with its text records as mjflex.flexure instances (method changed if given)."""
    copy = copy_spec(spec)
    records_to_plugins(copy)
    if method is not None:
        for plugin in copy.plugins:
            config = dict(plugin.config)
            config["method"] = method
            plugin.config = config
    return copy


def planar_spec(kind="record", method="twist", stops=None):
    """Two bodies on (slide x, slide y, hinge z) joints joined by one planar (3x3) element 'planar' (with ``stops``)."""
    spec = mujoco.MjSpec()
    spec.modelname = "planar"
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = 1e-3
    for name, x in (("A", 0.0), ("B", 0.1)):
        body = spec.worldbody.add_body(name=name, pos=[x, 0, 0])
        for axis in ([1, 0, 0], [0, 1, 0]):
            body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
        body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.01, 0.01], density=1000, contype=0,
                      conaffinity=0)  # fmt: skip
    K = np.array([[0.4, 0.02, -0.01], [0.02, 90.0, 4.0], [-0.01, 4.0, 120.0]])
    mjflex.add_flexure(spec, "planar", "A", "B", pos=[0.05, 0.0, 0.0], quat=[0.9, 0, 0, 0.3], K=K, B=0.02 * K,
                       method=method, kind=kind, stops=stops)  # fmt: skip
    return spec


def polynomial_terms(method, scale=20.0, seed=4):
    """Cubic and quartic terms (no stiffness at rest), random coefficients."""
    basis = mjflex.polynomial_basis(method, 4)
    return mjflex.PolynomialTerms(method, basis, scale * np.random.default_rng(seed).normal(size=len(basis)))


__all__ = ["B_DEMO", "K_DEMO", "MODELS", "as_plugins", "as_records", "planar_spec", "polynomial_terms"]
