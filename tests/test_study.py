"""``mjflex study``: the sweep against independent expectations, the variant path, the command line on
models that are not ours, and bad input.

Independent references: convergence orders of RK4 (4) and Euler (1), the closed-form stability
limits of a linear oscillator (symplectic Euler ``omega h < 2``, RK4 ``omega h < 2 sqrt 2``),
closed-form natural frequencies, and mjflex's own normal modes for the linearization.
"""

import contextlib
import io
import json
import os
import re

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.analysis.linearize import mass_matrix, normal_modes, stiffness_matrix
from mjflex.app.cli import main
from mjflex.app.study import Limit, StudyError, StudyResult, study
from mjflex.app.study._metrics import linearized_frequencies
from mjflex.variants.variant import Variant
from tests.models import ARM, B_DEMO, K_DEMO, hinge_arm_variant, hinge_chain_spec, pivot_arm_spec, slide_oscillator_spec

ROOT = os.path.join(os.path.dirname(__file__), "..")
TWO_BODY = os.path.join(ROOT, "models", "two_body.xml")
FAST = ["--repeat", "1", "--quiet"]


def _cli(*argv):
    """Run ``python -m mjflex`` in-process; returns ``(exit message or None, stdout)``."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            main([str(a) for a in argv])
        except SystemExit as exc:
            return str(exc.code), out.getvalue()
    return None, out.getvalue()


@pytest.fixture(scope="module")
def two_body_run(tmp_path_factory):
    """``python -m mjflex study models/two_body.xml`` narrowed to RK4 and Euler on four steps."""
    out = tmp_path_factory.mktemp("study")
    error, text = _cli("study", TWO_BODY, "--integrators", "rk4", "euler", "--methods", "twist", "--steps", 1.2e-4,
                       6e-5, 3e-5, 1.5e-5, "--bisect", 0, "--out", out, *FAST)  # fmt: skip
    assert error is None, error
    with open(out / "study_two_body.json") as f:
        return json.load(f), text, out


def _errors(rows, integrator, key="pose_error"):
    full = (r for r in rows if r["variant"] == "full")
    rows = sorted((r for r in full if r["integrator"] == integrator and r["source"] == "grid"),
                  key=lambda r: -r["timestep"])  # fmt: skip
    return np.array([r["timestep"] for r in rows]), np.array([r[key] for r in rows])


def test_stability_advice_follows_the_steps_given(two_body_run):
    """--steps was given: a limit not reached is widened with a larger step there, never with --max-step (which the
    study would refuse next to --steps)."""
    result, text, _ = two_body_run
    assert result["limits"] and all(lim["steps_given"] for lim in result["limits"])
    assert "--max-step" not in text and "--max-step" not in json.dumps(result)
    for lim in result["limits"]:
        if lim["smallest_unstable"] is None:
            assert "add a larger step to --steps" in Limit(**{**lim, "divergence": None}).text()


def test_errors_converge_at_the_integrators_orders(two_body_run):
    """Halving the step divides the error by ~16 for RK4 and ~2 for Euler.

    An error metric that measured anything but the integration error would not show the orders.
    Bounds: RK4 pose error ratio 12-20 (measured 16.2, 16.5; the maximum over time of the error
    at finite h carries higher-order terms), taken while the error is 10x above the error floor
    (3x the reference's estimated error), which then shifts a ratio by < 10 %. Euler energy error
    ratio 1.7-2.3 (measured 1.9, 1.95; its pose error ratios, 2.4-3.0, mix in second-order terms
    at these steps, so the energy shows the order more cleanly).
    """
    result, _, _ = two_body_run
    ref = result["reference"]
    assert ref["converged"] and ref["agreement"] <= 1e-6
    assert ref["error_estimate"] == pytest.approx(ref["agreement"] / 15)
    h, e = _errors(result["rows"], "rk4")
    np.testing.assert_allclose(h[:-1] / h[1:], 2.0, rtol=1e-9)
    resolved = e[1:] > 10 * result["error_floor"]
    assert resolved.sum() >= 2
    assert np.all((12 < (e[:-1] / e[1:])[resolved]) & ((e[:-1] / e[1:])[resolved] < 20))
    _, e = _errors(result["rows"], "euler", "energy_error")
    assert np.all((1.7 < e[:-1] / e[1:]) & (e[:-1] / e[1:] < 2.3))


def test_report_pareto_and_recommendation(two_body_run):
    result, text, out = two_body_run
    for ext in ("md", "json", "png"):
        assert os.path.getsize(out / f"study_two_body.{ext}") > 1000
    ok = [r for r in result["rows"] if r["status"] == "ok"]
    assert ok and all(r["cost"] > 0 and r["repeats"] == 1 for r in ok)
    for r in ok:  # the front: rows that no other row beats in both cost and error
        dominated = any(o["cost"] <= r["cost"] and o["pose_error"] < r["pose_error"] for o in ok if o is not r)
        assert r["pareto"] == (not dominated)
    own = [r for r in result["rows"] if r["model_setting"]]
    assert len(own) == 1 and own[0]["integrator"] == "rk4" and own[0]["timestep"] == pytest.approx(2e-5)
    assert "for <= 1 % error:" in text and "x faster than the reference" in text
    needs = {n["need"]: n for n in result["needs"]}
    # the choice for 1 %: the cheapest row that ran through at a recommended step within 1 % (computed from the rows
    # rather than a golden "euler, twist": which one is cheapest is a timing of this machine)
    usable = [r for r in ok if not r["beyond_limit"] and r["pose_error"] <= 0.01]
    best = min(usable, key=lambda r: r["cost"])
    assert (
        needs["engineering answers (pose error <= 1 %)"]["choice"] == f"{best['integrator']}, {best['method']}, "
        f"h = {best['timestep']:.3g} s"
    )
    assert any("'reduced_variant' does not apply: nothing to reduce below 2000 Hz" in n for n in result["notes"])
    assert needs["what the model file uses now"]["vs the model's setting"] == "the setting itself"


def test_a_report_is_made_again_from_its_json(two_body_run):
    """StudyResult.from_dict of a written JSON report gives that report back (to_dict) and the same Markdown, so a
    report can be written again when its wording changes, without running anything."""
    result, _, out = two_body_run
    again = StudyResult.from_dict(result)
    assert json.loads(json.dumps(again.to_dict(), default=float)) == result
    with open(out / "study_two_body.md") as f:
        assert again.to_markdown() == f.read()
    bracketed = [lim for lim in again.limits if lim.linear_step is not None]
    assert bracketed and all(lim.linear_step < lim.linear_unstable for lim in bracketed)
    assert all(lim.linear_unstable is None for lim in again.limits if lim.linear_step is None)
    older = {k: v for k, v in result.items() if k not in ("command", "notes", "targets", "fastest_rate_per_s")}
    older = StudyResult.from_dict(older)  # recorded before those fields existed: their defaults
    assert (older.command, older.notes, older.targets, older.fastest_rate) == ("", [], StudyResult.targets, None)
    assert older.rows == again.rows and older.limits == again.limits


def test_the_recorded_arcade_report_is_what_its_json_gives():
    """docs/study/study_arcade.md is what the study's writer makes of docs/study/study_arcade.json today (written
    again after a change of wording, with the one-liner below; the JSON, timed on an idle machine, stays)."""
    folder = os.path.join(ROOT, "docs", "study")
    with open(os.path.join(folder, "study_arcade.json")) as f:
        recorded = json.load(f)
    again = StudyResult.from_dict(recorded)
    written = json.loads(json.dumps(again.to_dict(), default=float))  # as the writer writes it
    assert {k: written[k] for k in recorded} == {**recorded, "limits": written["limits"]}  # the same, read back
    assert [{k: lim[k] for k in old} for lim, old in zip(written["limits"], recorded["limits"], strict=True)] == (
        recorded["limits"]
    )  # a report recorded before the linear bracket's upper end was: the field is new, the rest the same
    with open(os.path.join(folder, "study_arcade.md")) as f:
        assert f.read() == again.to_markdown(), (
            'docs/study/study_arcade.md is stale: python -c "import json; from mjflex.app.study import StudyResult; '
            "r = StudyResult.from_dict(json.load(open('docs/study/study_arcade.json'))); "
            "open('docs/study/study_arcade.md', 'w').write(r.to_markdown())\""
        )
    lines = [x for x in again.to_markdown().splitlines() if x.startswith("- rk4, twist: ")]
    assert len(lines) == 1 and "advised limit at or above 3.63e-05 s (the last stable step of its bisection" in lines[0]
    assert "linear limit" not in again.to_markdown().lower()  # one name, step_advice's: the advised limit


def test_stability_limits_match_closed_form():
    """A linear oscillator (w = 100 rad/s): the bisection brackets the theoretical limits.

    Symplectic Euler (MuJoCo's Euler, and implicitfast/discrete without joint damping) is stable
    for ``w h < 2``, RK4 for ``w h < 2 sqrt 2``. Above a limit the amplitude grows by a factor
    per step that tends to 1 at the limit, so a 5 s run cannot see the last ~0.1 %; the brackets
    must lie within 0.5 % of the limits and the divergence must name the element and the step.
    """
    w = 100.0
    model = slide_oscillator_spec(k=w**2, mass=1.0).compile()
    result = study(model, duration=5.0, samples=50, methods=("twist",), integrators=("euler", "rk4", "discrete"),
                   bisect=14, limit_rtol=0.002, repeat=1, progress=False)  # fmt: skip
    assert result.frequencies["full"][0] == pytest.approx(w / (2 * np.pi), rel=1e-7)
    for limit in result.limits:
        exact = (2.0 * np.sqrt(2.0) if limit.integrator == "rk4" else 2.0) / w
        assert exact * 0.995 <= limit.smallest_unstable and limit.largest_stable <= exact * 1.005
        assert limit.smallest_unstable / limit.largest_stable <= 1.0025
        div = limit.divergence
        assert div.element == "spring" and div.timestep == limit.smallest_unstable and div.time < 5.0
        assert "spring" in div.text() and f"{div.timestep:.3g}" in div.text()
        # the scene excites the only mode: the advised limit is the same one, bracketed to limit_rtol
        assert exact * 0.997 <= limit.linear_step <= exact * 1.002
        assert limit.linear_step < limit.linear_unstable <= limit.linear_step * 1.002 and exact <= limit.linear_unstable
        said = re.search(r"advised limit between (\S+) s \(stable\) and (\S+) s \(unstable\), set by the 15.92 Hz mode",
                         limit.text())  # fmt: skip
        lo, hi = float(said[1]), float(said[2])  # as many digits as tell them apart (3 would not here)
        assert (
            lo < hi
            and lo == pytest.approx(limit.linear_step, rel=1e-3)  # rounded to its digits
            and hi == pytest.approx(limit.linear_unstable, rel=1e-3)
        )
        assert limit.linear_mode["frequency_hz"] == pytest.approx(w / (2 * np.pi), rel=1e-6)
        assert limit.recommended == min(limit.largest_stable, limit.linear_step)
    assert not any(r.status == "ok" and r.timestep > 2.84 / w for r in result.rows)


def _failing_builder(model):
    raise RuntimeError("this builder does not apply here")


def test_variant_path_hinge_replacing_a_flexure():
    """A real variant (hinge with the compliant stiffness) through body_map and state_from.

    Closed form: the hinge model's frequency is ``sqrt(k_z / I_pivot)`` (linear joint spring);
    the full model's lowest one lies ~1e-5 below it (the pivot yields in the stiff directions).
    Over one period that frequency shift alone gives a pose error ~``2 pi df/f`` (phase drift
    times the amplitude): the variant's error at fine steps must be that, within a factor 2.
    """
    model = pivot_arm_spec().compile()
    bad = hinge_arm_variant(model)
    bad = Variant("bad state", bad.model, "wrong state size", bad.body_map, lambda m, d: (np.zeros(3), np.zeros(1)))
    result = study(model, variants=[hinge_arm_variant, _failing_builder, bad], methods=("twist",),
                   integrators=("rk4",), steps=[1e-4, 5e-5, 2.5e-5], bisect=0, repeat=1, progress=False)  # fmt: skip
    assert list(result.variants) == ["hinge"]
    assert any("this builder does not apply here" in n for n in result.notes)
    assert any("'bad state' left out" in n and "(1,)" in n for n in result.notes)
    pivot_inertia = ARM["inertia"][2] + ARM["mass"] * (ARM["length"] / 2) ** 2
    f_hinge = np.sqrt(ARM["k_z"] / pivot_inertia) / (2 * np.pi)
    assert result.frequencies["hinge"][0] == pytest.approx(f_hinge, rel=1e-8)
    f_full = result.frequencies["full"][0]
    assert 1e-6 < (f_hinge - f_full) / f_hinge < 1e-4
    hinge = [r for r in result.rows if r.variant == "hinge"]
    assert len(hinge) == 3 and all(r.status == "ok" and r.method == "-" for r in hinge)
    assert hinge[-1].frequency_error == pytest.approx((f_hinge - f_full) / f_full, rel=1e-6)
    assert hinge[-1].note == "has 1 of the reference's first 3 elastic modes"
    full = [r for r in result.rows if r.variant == "full" and r.status == "ok"]
    assert hinge[-1].pose_error > 10 * max(r.pose_error for r in full)
    assert 0.5 < hinge[-1].pose_error / (2 * np.pi * hinge[-1].frequency_error) < 2.0


def test_linearization_matches_normal_modes():
    """The study's linearization of qacc against mjflex's generalized forces + mass matrix + eigh."""
    model = mujoco.MjModel.from_xml_path(TWO_BODY)
    flex = mjflex.Flexures(model)
    freq, highest, _ = linearized_frequencies(model, flex, model.qpos0)
    reference = normal_modes(model, flex)[0]
    np.testing.assert_allclose(freq, reference[-len(freq) :], rtol=1e-8)
    assert highest == pytest.approx(reference[-1], rel=1e-10)


def test_cli_on_a_user_chain(tmp_path):
    """A model that is not ours: a grounded chain of hinge, slide and ball joints with a keyframe."""
    spec = hinge_chain_spec(n=3, K=K_DEMO, B=B_DEMO)
    model = spec.compile()
    rng = np.random.default_rng(3)
    spec.add_key(name="kick", qvel=rng.normal(size=model.nv))
    path = tmp_path / "chain.xml"
    path.write_text(spec.to_xml())
    error, text = _cli("study", path, "--integrators", "rk4", "euler", "--methods", "twist", "dualquat",
                       "--step-count", 3, "--bisect", 3, "--duration", 0.05, "--out", tmp_path, *FAST)  # fmt: skip
    assert error is None, error
    result = json.loads((tmp_path / "study_chain.json").read_text())
    assert result["initial_state"] == "keyframe 'kick'" and result["frame"] == "the world"
    assert result["tracked"] == ["link0", "link1", "link2"]
    assert sum(r["status"] == "ok" for r in result["rows"]) >= 4
    assert "for <= 1 % error:" in text


def test_no_flexures(tmp_path):
    path = tmp_path / "plain.xml"
    path.write_text('<mujoco model="plain"><worldbody><body name="b"><freejoint/><geom size="0.1"/></body>'
                    '</worldbody><keyframe><key qvel="1 0 0 0 0 0"/></keyframe></mujoco>')  # fmt: skip
    out = tmp_path / "out"
    error, _ = _cli("study", path, "--out", out, *FAST)
    assert "has no mjflex elements" in error and "add_flexure" in error
    assert not out.exists()  # refused before anything ran or was written


def test_no_initial_state(tmp_path):
    with open(TWO_BODY) as f:
        text = f.read()
    path = tmp_path / "still.xml"
    path.write_text(text[: text.index("<keyframe>")] + "</mujoco>\n")
    with pytest.raises(StudyError, match=r"no initial state.*at rest and in equilibrium.*keyframe") as exc:
        study(str(path), out=tmp_path / "out", progress=False)
    assert exc.value.partial is None and not exc.value.paths and not (tmp_path / "out").exists()
    with pytest.raises(StudyError, match="no keyframe 'nope'"):
        study(TWO_BODY, keyframe="nope", progress=False)


def test_diverges_at_every_candidate_step(tmp_path):
    """Steps far past the limit: every candidate diverges, each reported with element and step;
    the command exits with the message and the partial results are written."""
    error, _ = _cli("study", TWO_BODY, "--integrators", "euler", "rk4", "--methods", "twist", "--steps", 4e-3, 2e-3,
                    "--bisect", 0, "--no-variants", "--out", tmp_path, *FAST)  # fmt: skip
    assert "every candidate step diverged" in error
    result = json.loads((tmp_path / "study_two_body.json").read_text())
    grid = [r for r in result["rows"] if r["source"] != "model"]
    assert len(grid) == 4 and all(r["status"] == "diverged" for r in grid)
    assert all(r["divergence"]["element"] == "hinge" and r["divergence"]["timestep"] == r["timestep"] for r in grid)
    assert all(lim["largest_stable"] is None for lim in result["limits"])
    assert "diverged" in (tmp_path / "study_two_body.md").read_text()


def test_reference_diverges(tmp_path):
    with pytest.raises(StudyError, match=r"reference \(RK4\) did not run through") as exc:
        study(TWO_BODY, steps=[4e-3], reference_step=4e-3, max_refinements=1, out=tmp_path, progress=False)
    attempts = exc.value.partial.reference.attempts
    assert [a["timestep"] for a in attempts] == pytest.approx([4e-3, 2e-3])
    assert all("flexure 'hinge'" in a["status"] for a in attempts)
    assert json.loads((tmp_path / "study_two_body.partial.json").read_text())["reference"]["attempts"]
    assert not (tmp_path / "study_two_body.json").exists()  # beside, never in place of, complete results


def test_bad_choices():
    with pytest.raises(StudyError, match=r"unknown choice.*'rk5'"):
        study(TWO_BODY, integrators=("rk5",), progress=False)
    with pytest.raises(StudyError, match="not found"):
        study("no/such/model.xml", progress=False)


def test_a_spec_is_studied_and_reaches_the_variant_builders():
    """Builders get what the study was given (here an MjSpec, which MuJoCo cannot recover from a
    compiled model), so mjflex's own weld variant can rebuild the model from it; a builder with
    nothing to build is noted, not run."""
    seen = []

    def nothing_to_do(source):
        seen.append(type(source))
        raise mjflex.VariantNotApplicableError("nothing here")

    result = study(pivot_arm_spec(), variants=[mjflex.weld_variant, nothing_to_do], methods=("twist",),
                   integrators=("rk4",), steps=[1e-4], bisect=0, repeat=1, progress=False)  # fmt: skip
    assert seen == [mujoco.MjSpec]
    assert list(result.variants) == ["weld(compliant)"]
    assert any("'nothing_to_do' does not apply: nothing here" in n for n in result.notes)
    weld = [r for r in result.rows if r.variant == "weld(compliant)"]
    assert weld and all(r.status == "ok" for r in weld)


def _rk4_limit(lam):
    """Largest h with |R(h lambda)| <= 1 for every eigenvalue (R: RK4's stability polynomial), by bisection."""

    def stable(h):
        z = h * lam
        return np.all(np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1 + 1e-12)

    return _bisect_limit(stable, 3.0 / np.abs(lam).max())


def _bisect_limit(stable, hi):
    lo = hi / 64
    assert stable(lo) and not stable(hi)
    for _ in range(60):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def test_linear_stability_limit_and_the_mode_the_scene_leaves_unexcited():
    """two_body's planar swing never moves its stiffest (out-of-plane, 1882 Hz) mode.

    Its measured limits (RK4 2.82e-4 s, Euler 1.84e-4 s) are 1.14x / 1.15x those of the model
    linearized at rest, where a 1e-6 velocity perturbation diverges. Independent reference of the
    advised limits: mjflex's own stiffness and mass matrices and the elements' damping (central
    differences of their generalized forces over the velocities), then RK4's stability polynomial
    on the eigenvalues of the first-order system, and the one-step map of MuJoCo's Euler
    (semi-implicit: v' = v + h a(q, v), q' = q + h v') in closed form. The study's bracket lies
    within limit_rtol (2 %) below these, and its 2x-growth-over-the-run allowance can put it at
    most ~1e-3 above.
    """
    result = study(TWO_BODY, methods=("twist",), integrators=("rk4", "euler"), variants=[], repeat=1, progress=False)
    model = mujoco.MjModel.from_xml_path(TWO_BODY)
    flex = mjflex.Flexures(model)
    K, M = stiffness_matrix(model, flex), mass_matrix(model)
    data, eps, C = mujoco.MjData(model), 1e-6, np.zeros((model.nv, model.nv))
    for i in range(model.nv):
        f = []
        for sign in (1.0, -1.0):
            data.qpos[:], data.qvel[:] = model.qpos0, 0.0
            data.qvel[i] = sign * eps
            mujoco.mj_forward(model, data)
            f.append(flex.generalized_forces(data))
        C[:, i] = -(f[0] - f[1]) / (2 * eps)
    A, D, n = np.linalg.solve(M, K), np.linalg.solve(M, C), model.nv
    lam = np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [-A, -D]]))
    I = np.eye(n)

    def euler_stable(h):
        G = np.block([[I - h * h * A, h * (I - h * D)], [-h * A, I - h * D]])
        return np.abs(np.linalg.eigvals(G)).max() <= 1 + 1e-6

    exact = {"rk4": _rk4_limit(lam[np.abs(lam) > 1e-6 * np.abs(lam).max()]), "euler": _bisect_limit(euler_stable, 3e-4)}
    f_max = np.sqrt(np.linalg.eigvals(A).real.max()) / (2 * np.pi)
    # the dominant direction of that mode, from the element's own displacement along it (K is diagonal)
    w2, phi = np.linalg.eig(A)
    top = phi[:, np.argmax(w2.real)].real
    data.qpos[:], data.qvel[:] = model.qpos0, 0.0
    mujoco.mj_integratePos(model, data.qpos, 1e-6 * top / np.abs(top).max(), 1.0)
    mujoco.mj_kinematics(model, data)
    energy = 0.5 * np.diag(flex.records[0].K) * flex.displacements(data)[0] ** 2
    label = ("rx", "ry", "rz", "x", "y", "z")[int(np.argmax(energy))]
    for lim in result.limits:
        h = exact[lim.integrator]
        assert h * (1 - 0.021) <= lim.linear_step <= h * 1.002, (lim.integrator, lim.linear_step, h)
        assert h <= lim.linear_unstable <= lim.linear_step * 1.02  # the bisection's bracket holds the limit
        assert lim.largest_stable > 1.1 * lim.linear_step  # the scene alone would claim 10 % more
        mode = lim.linear_mode
        assert mode["frequency_hz"] == pytest.approx(f_max, rel=1e-3) and mode["oscillating"]
        assert mode["where"] == f"element 'hinge' {label}" and mode["kind"] == "strain" and mode["share"] > 0.99
        assert mode["scene_share"] < 1e-20  # planar scene, out-of-plane mode: not even round-off
        # the perturbed scene diverges at the measured limit and runs through at the recommended (linear) one
        at = {c["timestep"]: c["status"] for c in lim.checks}
        assert at[lim.largest_stable] == "diverged" and at[lim.linear_step] == "ok"
        assert lim.recommended == lim.linear_step
        assert "leaves that mode unexcited" in lim.text() and f"Use h <= {lim.linear_step:.3g} s" in lim.text()
    for row in result.rows:  # rows above the recommended step ran through only because of the scene
        lim = next(x for x in result.limits if x.integrator == row.integrator)
        assert row.beyond_limit == (row.status == "ok" and row.timestep > lim.recommended * (1 + 1e-9))
    flagged = [r for r in result.rows if r.beyond_limit]
    assert flagged and not any(r.pareto for r in flagged)
    assert not any(r in flagged for r in (result.cheapest(t) for t in result.targets))
