"""What a MuJoCo user would build without mjflex: welds, joint springs and 6-joint bushings.

Each builder takes a model with mjflex elements and returns a
:class:`~mjflex.variants.variant.Variant` in which the elements are replaced by MuJoCo's own
modelling, matched to the elements as far as MuJoCo allows; the report says what could not be
matched.

* :func:`weld_variant`: every element becomes a ``weld`` equality between its two sites. A
  soft weld is a penalty spring whose constraint-space stiffness is set by ``solref``: in the
  direct format ``(-s, -c)`` with a small constant impedance ``d`` (``solimp``), MuJoCo's soft
  constraint reduces to a spring of stiffness ``s / A_ii`` per row, where ``A_ii`` is the
  solver's approximate inverse inertia of the row, frozen at ``qpos0`` (read back from
  ``efc_R = (1 - d) / d A_ii``). The three translational rows share one stiffness
  ``k_t = s / A_t``; the rotational rows measure the quaternion error scaled by
  ``torquescale`` ``ts``, giving ``k_r = s ts^2 / (4 A_r)`` (measured: see the tests). Two
  numbers (``s`` and ``ts``) thus set one isotropic translational and one isotropic rotational
  stiffness about the element origin; the damping ``c`` follows the same law, so ``B`` is
  matched only when it is proportional to ``K``. Anisotropy (a notch hinge is 150 times
  stiffer out of plane than about its axis), coupling and the exact large-rotation law cannot be
  matched; ``match`` picks which eigenvalue of each block to honour. ``match="rigid"`` gives
  the usual stiff weld (``solref = (2 h, 1)``) instead.
* :func:`pseudo_rigid_body_variant`: every element becomes one joint (hinge or slide) in its
  most compliant direction (lowest local frequency, see :mod:`mjflex.analysis.directions`) with
  that direction's stiffness and damping as MuJoCo joint ``stiffness`` / ``damping``; all other
  directions rigid. Loops are closed by two ``connect`` constraints on the closing hinge's
  axis; its spring is a fixed tendon over the loop's joints whose coefficients are the closing
  rotation's Jacobian at ``qpos0`` (exact for planar loops, first order otherwise).
* :func:`bushing_variant`: every element becomes three slides and three hinges in series at
  its centre of stiffness, along its principal axes, with the principal stiffnesses and
  damping (couplings dropped); loop-closing elements become matched soft welds.
"""

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from ..analysis.directions import element_directions, element_matrices, relative_jacobian
from ..mjcf import schema
from ..mjcf.spec import compile_spec
from .assemble import assemble, hinge_closure
from .tree import free_world_bodies, joints_of, link_of, retired_sites
from .variant import (
    PoseFit,
    Variant,
    body_names,
    identity_body_map,
    keeps_element_kinds,
    polynomial_terms_lines,
    source_elements,
    stops_lines,
)

_LINEAR = "are not represented: the replacement holds its stiffness at rest K only"
_NO_STOPS = "are not represented: the replacement has no range (give its joints ranges, or keep the element)"

WELD_MATCHES = ("compliant", "mean", "stiff", "rigid")
#: Impedance of the matched welds: small, so that the constraint acts as a spring (the solver
#: then also absorbs this fraction of the unconstrained acceleration along the weld).
WELD_IMPEDANCE = 1e-4
TORQUESCALE = 10  # index of torquescale in a weld's eq_data (after anchor and relpose)


def _pick(values, match):
    values = np.sort(np.asarray(values))
    return {"compliant": values[0], "mean": float(np.mean(values)), "stiff": values[-1]}[match]


def weld_targets(record, match):
    """Isotropic ``(k_t, k_r, beta)`` a weld can hold for an element: stiffness [N/m, N m/rad], damping/stiffness [s].

    ``match`` picks the smallest (``"compliant"``), mean or largest eigenvalue of the
    translational and rotational blocks of ``K`` (element frame, about its origin);
    ``beta`` is the damping ratio ``b / k`` of the matched rotational eigen-direction.
    """
    K, B = element_matrices(record)
    lam_r, vec_r = np.linalg.eigh(K[:3, :3])
    k_t, k_r = _pick(np.linalg.eigvalsh(K[3:, 3:]), match), _pick(lam_r, match)
    v = vec_r[:, int(np.argmin(np.abs(lam_r - k_r)))]
    beta = float(v @ B[:3, :3] @ v / max(v @ K[:3, :3] @ v, 1e-300))
    return float(k_t), float(k_r), beta


def _retire(spec, flex, element):
    """Drop an element's record and rename its sites (:func:`retired_sites`); returns their new names."""
    spec.delete(spec.text(schema.PREFIX + element))
    new = retired_sites(element)
    for site_id, name in zip(flex.site_ids[flex.index(element)], new, strict=True):
        spec.site(mujoco.mj_id2name(flex.model, mujoco.mjtObj.mjOBJ_SITE, int(site_id))).name = name
    return new


def _add_weld(spec, element, sites, solref, solimp, torquescale=1.0):
    weld = spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_SITE, name=f"{element}:weld",
                             name1=sites[0], name2=sites[1], solref=solref, solimp=solimp)  # fmt: skip
    weld.data[TORQUESCALE] = torquescale
    return weld


def _weld_inverse_inertias(model):
    """Per weld: the solver's approximate inverse inertia of its translational and rotational rows."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    out = {}
    for row in range(data.nefc):
        if data.efc_type[row] == mujoco.mjtConstraint.mjCNSTR_EQUALITY:
            eq = int(data.efc_id[row])
            out.setdefault(eq, []).append(data.efc_R[row] * WELD_IMPEDANCE / (1.0 - WELD_IMPEDANCE))
    return {eq: (float(np.mean(r[:3])), float(np.mean(r[3:6]))) for eq, r in out.items()}


def matched_welds(spec, flex, elements, match):
    """Replace ``elements`` (names) of ``spec`` by welds matched to them; returns report lines."""
    solimp = [WELD_IMPEDANCE, WELD_IMPEDANCE, 0.001, 0.5, 2.0]
    welds, lines = {}, []
    for name in elements:
        welds[name] = _add_weld(spec, name, _retire(spec, flex, name), [-1.0, 0.0], solimp)
    model = compile_spec(spec, why=None)
    inverse = _weld_inverse_inertias(model)
    eq_ids = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, i): i for i in range(model.neq)}
    for name, weld in welds.items():
        rec = flex.records[flex.index(name)]
        k_t, k_r, beta = weld_targets(rec, match)
        A_t, A_r = inverse[eq_ids[f"{name}:weld"]]
        s = k_t * A_t
        ts = float(np.sqrt(4.0 * k_r * A_r / s))
        weld.solref = [-s, -beta * s]
        weld.data[TORQUESCALE] = ts
        diag = np.diag(element_matrices(rec)[0])
        lines.append(
            f"{name}: weld k_t {k_t:.4g} N/m (element {', '.join(f'{x:.3g}' for x in diag[3:])}), k_r "
            f"{k_r:.4g} N m/rad (element {', '.join(f'{x:.3g}' for x in diag[:3])}), damping {beta:.3g} K; "
            f"solref ({-s:.4g}, {-beta * s:.4g}), torquescale {ts:.4g}"
        )
    return lines


@keeps_element_kinds
def weld_variant(source, *, match="compliant", name=None) -> Variant:
    """Every element of ``source`` replaced by a MuJoCo weld between its sites (module docstring).

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        The model with mjflex elements (:func:`mjflex.variants.variant.source_spec`).
    match : {"compliant", "mean", "stiff", "rigid"}
        Which eigenvalue of each stiffness block the isotropic weld honours, or a stiff weld.
    name : str, optional
        Label of the variant (default ``"weld(<match>)"``).

    Returns
    -------
    Variant
        The model with one weld equality per element; ``report`` gives each weld's stiffness
        against the element's.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    >>> variant = mjflex.weld_variant(spec)
    >>> variant.name, variant.model.neq, variant.model.nv
    ('weld(compliant)', 1, 6)
    """
    if match not in WELD_MATCHES:
        raise ValueError(f"match={match!r}: use one of {WELD_MATCHES}")
    spec, model, flex = source_elements(source, "replace")
    if match == "rigid":
        for n in flex.names:
            _add_weld(spec, n, _retire(spec, flex, n), [2.0 * model.opt.timestep, 1.0], [0.9, 0.95, 0.001, 0.5, 2.0])
        lines = [
            f"{len(flex)} elements replaced by stiff welds (solref = (2 h, 1) = ({2 * model.opt.timestep:g}, 1)): "
            "the bodies move as one up to the constraint softness, which the solver sets, not the flexures"
        ]
    else:
        lines = matched_welds(spec, flex, flex.names, match)
        lines.insert(
            0,
            f"{len(flex)} elements replaced by soft welds matched to the '{match}' eigenvalue of each block:"
            " isotropic, uncoupled, quaternion-error law; anisotropy and coupling are lost",
        )
    lines += polynomial_terms_lines(flex, _LINEAR) + stops_lines(flex, _NO_STOPS)
    variant_model = compile_spec(spec, why=None)
    body_map = identity_body_map(variant_model)
    details = {"match": match, "welds": len(flex), "nv": int(variant_model.nv), "constraints": "spring"}
    return Variant(
        name or f"weld({match})",
        variant_model,
        "\n".join(lines),
        body_map,
        PoseFit(variant_model, body_map, constraints=False),
        details,
        spec,
    )


def _links(model, flex, choose):
    """``(dirs, links)``: the elements' :class:`~mjflex.analysis.directions.Directions`, each between free bodies of
    the world, and their links with joints in the directions ``choose(d)``."""
    dirs = element_directions(model, flex)
    free = free_world_bodies(model)
    names = body_names(model)
    for d in dirs:
        for b in (d.body_a, d.body_b):
            if b and names[b] not in free:
                raise ValueError(
                    f"element {d.element!r}: body {names[b]!r} is not a free body of the world; joint "
                    "variants re-joint free bodies only (mjflex's convention)"
                )
    return dirs, [link_of(d, names, joints_of(d, choose(d))) for d in dirs]


class _TendonSprings:
    """Loop-closing hinges: two connects now, a fixed tendon spring over the loop's joints after compiling."""

    def __init__(self, arm):
        self.pending, self.arm = [], arm

    def close(self, tree, link):
        if len(link.joints) != 1 or link.joints[0].kind != "hinge":
            return f"{link.element}: closes a loop with a non-hinge joint; kept as an mjflex element (not native)"
        hinge_closure(tree, link, link.joints[0], self.arm)
        tree.drop_element(link.element, link.sites)
        self.pending.append(link)
        return None

    def post(self, tree, model):
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        ids = {n: i for i, n in enumerate(body_names(model))}
        lines = []
        for link in self.pending:
            j = link.joints[0]
            coef = j.axis @ relative_jacobian(model, data, ids[link.body_a], ids[link.body_b], j.point, np.eye(3))[:3]
            fixed = tree.add(
                "tendon",
                "fixed",
                name=f"{link.element}:spring",
                stiffness=f"{j.stiffness:.17g}",
                damping=f"{j.damping:.17g}",
                springlength="0 0",
            )
            for dof in np.nonzero(np.abs(coef) > 1e-12 * np.abs(coef).max())[0]:
                jnt = model.dof_jntid[dof]
                if int(model.jnt_type[jnt]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                    raise ValueError(f"loop of {link.element!r} runs through a ball or free joint; no fixed tendon")
                jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jnt)
                ET.SubElement(fixed, "joint", {"joint": jname, "coef": f"{coef[dof]:.17g}"})
            lines.append(
                f"{link.element}: closes a loop as a hinge (two connects); its spring {j.stiffness:.4g} is a "
                f"fixed tendon over {len(fixed)} joints (coefficients from the Jacobian at qpos0)"
            )
        return lines


@keeps_element_kinds
def pseudo_rigid_body_variant(source, *, name=None) -> Variant:
    """Every element of ``source`` replaced by one MuJoCo joint with a spring (module docstring).

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        The model with mjflex elements (:func:`mjflex.variants.variant.source_spec`).
    name : str, optional
        Label of the variant (default ``"pseudo-rigid-body"``).

    Returns
    -------
    Variant
        The model with one hinge or slide per element, in its most compliant direction, with
        that direction's stiffness and damping as MuJoCo joint ``stiffness`` and ``damping``.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    >>> variant = mjflex.pseudo_rigid_body_variant(spec)
    >>> print(variant.report.splitlines()[1])  # one hinge about the element's z axis, 1 N m/rad
    leaf: hinge rz, stiffness 1
    """
    spec, model, flex = source_elements(source, "replace")
    dirs, links = _links(model, flex, lambda d: [int(np.argmin(np.where(d.k > 0, d.local_hz, np.inf)))])
    springs = _TendonSprings(0.1 * max(float(model.stat.extent), 1e-3))
    report = [f"{len(dirs)} elements replaced by one joint each, in their most compliant direction (all others rigid):"]
    report += [
        f"{link.element}: {link.joints[0].kind} {link.joints[0].label}, stiffness {link.joints[0].stiffness:.4g}"
        for link in links
    ]
    report += polynomial_terms_lines(flex, _LINEAR) + stops_lines(flex, _NO_STOPS)
    return assemble(
        spec,
        model,
        links,
        closer=springs.close,
        post=springs.post,
        name=name or "pseudo-rigid-body",
        report=report,
        details={"kind": "pseudo_rigid_body"},
    )


@keeps_element_kinds
def bushing_variant(source, *, loop_welds="compliant", name=None) -> Variant:
    """Every element of ``source`` replaced by a 6-joint bushing (module docstring).

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        The model with mjflex elements (:func:`mjflex.variants.variant.source_spec`).
    loop_welds : {"compliant", "mean", "stiff", "rigid"}
        The ``match`` of the soft welds that close loops (see :func:`weld_variant`).
    name : str, optional
        Label of the variant (default ``"bushing"``).

    Returns
    -------
    Variant
        The model with three slides and three hinges per element at its centre of stiffness,
        along its principal axes, with the principal stiffnesses and damping; the couplings
        dropped are in ``report``.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    >>> variant = mjflex.bushing_variant(spec)
    >>> variant.name, variant.model.njnt, variant.model.nv
    ('bushing', 6, 6)
    """
    spec, model, flex = source_elements(source, "replace")
    order = [3, 4, 5, 0, 1, 2]  # slides first, then hinges, all through the centre of stiffness
    dirs, links = _links(model, flex, lambda d: [i for i in order if d.k[i] > 0])
    closers = []  # closed by matched soft welds once compiled (_weld_loops)
    coupled = ", ".join(f"{d.element} {d.coupling:.2g}" for d in dirs if d.coupling > 1e-9) or "none"
    report = [
        f"{len(dirs)} elements replaced by up to six joints each (three slides, three hinges) with their principal "
        f"stiffness and damping; couplings dropped (largest normalized off-diagonal stiffness): {coupled}",
        *polynomial_terms_lines(flex, _LINEAR),
        *stops_lines(flex, _NO_STOPS),
    ]
    details = {"kind": "bushing", "constraints": "spring"}
    variant = assemble(spec, model, links, closer=lambda tree, link: closers.append(link.element),
                       name=name or "bushing", report=report, details=details)  # fmt: skip
    if closers:
        variant = _weld_loops(variant, flex, closers, loop_welds)
    return variant


def _weld_loops(variant, flex, closers, match):
    """Replace the loop-closing elements of a joint variant by matched soft welds (needs the compiled tree)."""
    spec = variant.spec
    lines = matched_welds(spec, flex, closers, match)
    model = compile_spec(spec, why=None)
    variant.model = model
    variant.state_from = PoseFit(model, variant.body_map, constraints=False)
    variant.report += "\nloops closed by matched soft welds:\n" + "\n".join(lines)
    variant.details["loop_welds"] = closers
    return variant


__all__ = ["bushing_variant", "pseudo_rigid_body_variant", "weld_targets", "weld_variant"]
