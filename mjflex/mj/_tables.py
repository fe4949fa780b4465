"""What :class:`mjflex.Flexures` reads from a model: its elements, parsed, checked and laid out
in the element table that the C loop reads (one ``mjflex.mj._native.ELEMENT_DTYPE`` row each).

An element is written in a model file either as a text record with two sites
(:mod:`mjflex.mj.schema`) or as an instance of the engine plugin ``mjflex.flexure``
(``schema.PLUGIN_ATTRIBUTES``); both give the same table row, so every analysis works on both.

:func:`derive` is the single place where a model is read; the provider runs it once at
construction, and again on a model it is asked to serve (a copy) to check that the copy holds
the same elements in the same places.
"""

import difflib
import hashlib
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from ..core import validation
from ..core.transforms import twist_from_transform
from . import _contacts, _native, schema

RECORD, PLUGIN = "record", "plugin"


class ModelError(ValueError):
    """A flexure element of a model is malformed; the message names the element and the fix."""


def model_error(element, problem, fix):
    return ModelError(f"flexure '{element}': {problem}. {fix}")


@dataclass
class Tables:
    """The elements of one model: text-record elements first, then plugin instances.

    ``elements`` (n,) ``ELEMENT_DTYPE``; ``chain`` the dofs each non-free body's wrench maps to
    (ranges ``chain_*0:chain_*1`` of a row); ``exps`` (M, 8) and ``coefs`` (M,) the polynomial
    terms of all elements (rows ``terms_lo:terms_hi`` of a row). The arrays are C-contiguous
    and never empty (the C loop gets valid addresses).
    """

    names: tuple[str, ...]
    texts: dict[str, str]  # element -> its record's JSON data, or its plugin configuration as text
    records: list
    sites: list[tuple[str, str]]  # element -> (site a name, site b name)
    kinds: tuple[str, ...]  # element -> RECORD or PLUGIN
    instances: tuple[int, ...]  # element -> plugin instance id (-1 for a record)
    elements: np.ndarray
    chain: np.ndarray
    tolerance: np.ndarray  # (n,) coincidence tolerance [m] of each element
    joined_trees: dict[int, str]  # tree -> an element that joins it to another tree or a mocap body
    exps: np.ndarray
    coefs: np.ndarray

    @property
    def served(self) -> int:
        """Number of text-record elements (the first rows): the ones the mjcb_passive provider adds."""
        return self.kinds.count(RECORD)


def names(model, objtype, count):
    return [mujoco.mj_id2name(model, objtype, i) or "" for i in range(count)]


def fingerprint(model) -> bytes:
    """A digest of everything :func:`derive` reads: unchanged digest, unchanged tables."""
    h = hashlib.blake2b(digest_size=16)
    for a in (model.text_data, model.text_adr, model.names, model.site_pos, model.site_quat, model.site_bodyid,
              model.body_pos, model.body_quat, model.body_parentid, model.qpos0, model.jnt_pos, model.jnt_axis,
              model.body_mass, model.body_inertia, model.plugin, model.plugin_attr, model.plugin_attradr):  # fmt: skip
        h.update(np.ascontiguousarray(a).tobytes())
    return h.digest()


def _records(model, site_ids, claimed_sites=()):
    """``[(element, data, site a, site b, found)]`` of the model's records; warns about near misses."""
    out = []
    for i, tname in enumerate(names(model, mujoco.mjtObj.mjOBJ_TEXT, model.ntext)):
        try:
            match = schema.match_record(tname, site_ids)
        except ValueError as exc:
            raise ModelError(f"flexure record '{tname}': {exc}") from None
        if match is None:
            if schema.near_miss(tname):
                warnings.warn(
                    f"mjflex: text record '{tname}' looks like a flexure record but is not one (records are "
                    f"named '{schema.PREFIX}<element>'); rename it if it should be an element",
                    UserWarning,
                    stacklevel=4,
                )
            continue
        adr, size = model.text_adr[i], model.text_size[i]
        out.append((*match[:1], bytes(model.text_data[adr : adr + size - 1]).decode("utf-8"), *match[1:]))
    claimed = {r[2] for r in out} | set(claimed_sites)
    for element in schema.orphan_site_pairs(site_ids, claimed):
        warnings.warn(
            f"mjflex: sites of an element '{element}' have no text record '{schema.PREFIX}{element}' and no "
            f"{schema.PLUGIN_NAME} instance: the element is not simulated. Add it (mjflex.add_flexure writes both), "
            "or rename the sites. A model composed with MjSpec.attach or copied with MjSpec.copy loses the plugin "
            "instances no body references (MuJoCo 4.0): use mjflex.attach / mjflex.copy_spec",
            UserWarning,
            stacklevel=4,
        )
    return out


def parse(element, data):
    try:
        return schema.parse_text(element, data)
    except ValueError as exc:
        problem = f"text record '{schema.PREFIX}{element}' is malformed: {str(exc).rstrip('.')}"
        raise model_error(element, problem, "Fix its text record (see mjflex.mj.schema for the keys).") from None


def _site_id(model, element, name, role, all_sites, others):
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    if sid < 0:
        close = difflib.get_close_matches(name, [s for s in all_sites if s not in others], n=3, cutoff=0.6)
        hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise model_error(
            element, f"site '{name}' not found",
            f"Add <site name=\"{name}\"/> at the element frame ({role}) or rename the existing site.{hint}",
        )  # fmt: skip
    return sid


def _dof_chain(model, body):
    """Dofs whose motion moves ``body``, from its own last dof to the root."""
    while body > 0 and model.body_dofnum[body] == 0:
        body = model.body_parentid[body]
    if body == 0:
        return []
    j, chain = model.body_dofadr[body] + model.body_dofnum[body] - 1, []
    while j >= 0:
        chain.append(int(j))
        j = model.dof_parentid[j]
    return chain


def _free_dofadr(model, body):
    """Dof address of a free joint that is the only joint of a child of the world, else -1."""
    if body > 0 and model.body_parentid[body] == 0 and model.body_jntnum[body] == 1:
        j = model.body_jntadr[body]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            return int(model.jnt_dofadr[j])
    return -1


def _length_scale(model, sa, sb):
    """Summed lengths [m] of the site and body positions that place sites ``sa`` and ``sb``."""
    total = float(np.linalg.norm(model.site_pos[sa]) + np.linalg.norm(model.site_pos[sb]))
    for site in (sa, sb):
        body = int(model.site_bodyid[site])
        while body > 0:
            total += float(np.linalg.norm(model.body_pos[body]))
            body = int(model.body_parentid[body])
    return total


def rest_offset(ref, sa, sb):
    """Relative pose ``(R0, p0)`` of site b seen from site a in data ``ref`` (at ``qpos0``), and
    its distance [m] and angle [rad].

    Computed by the native library, exactly as the engine plugin's ``init`` computes it, so that a
    text record and a plugin instance of one element are bit-identical.
    """
    return _native.rest_offset(ref, sa, sb)


def _coincide(dist, angle, tol):
    """Whether a distance and an angle are within the coincidence tolerances (NaN is not: ``NaN > tol`` is false)."""
    return dist <= tol and angle <= schema.COINCIDENCE_ANGLE


_NONFINITE = (
    "Their pose at qpos0 is not finite: a position, orientation or joint reference (qpos0) that places them is NaN "
    "or infinite; give finite numbers."
)


def _check_coincident(element, sites, dist, angle, tol):
    if not np.isfinite([dist, angle, tol]).all():
        raise model_error(element, f"sites '{sites[0]}' and '{sites[1]}' are {dist:.3g} m and {angle:.3g} rad apart "
                          "at qpos0", _NONFINITE)  # fmt: skip
    if not _coincide(dist, angle, tol):
        raise model_error(
            element,
            f"sites '{sites[0]}' and '{sites[1]}' are {dist:.3g} m apart and {angle:.3g} rad apart at qpos0 "
            f"(tolerance {tol:.3g} m: {schema.COINCIDENCE_RTOL:g} times the {tol / schema.COINCIDENCE_RTOL:.3g} m "
            f"of site and body positions that place them, which covers their 6-digit rounding in saved files; "
            f"{schema.COINCIDENCE_ANGLE:g} rad)",
            "Both frames must coincide in the reference configuration: place both at the same world "
            "pose (mjflex.add_flexure does this).",
        )


def _frame_site_id(model, element, site, site_a):
    """Id of the record's frame site ``site``, or -1: under ``MjSpec.attach`` it carries the element's
    prefix and suffix (``element = P + E + S``, ``site_a = P + E + "/a" + S``), so ``P + site + S``
    is tried for every split of ``P + E``."""
    c = next((i for i, (x, y) in enumerate(zip(element, site_a, strict=False)) if x != y), len(element))
    names = [element[:i] + site + t for i in range(c, -1, -1) for t in (element[c:], "")]
    for name in dict.fromkeys(names):
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
        if sid >= 0:
            return sid
    return -1


def _check_frame_site(model, ref, element, site, site_a, tol):
    """The record names the site that gives the element frame: frame a must still coincide with it."""
    sid = _frame_site_id(model, element, site, site_a[0])
    if sid < 0:
        raise model_error(
            element, f"its record names the frame site '{site}', which the model does not have",
            "Restore the site, or drop \"site\" from the record if the element's own sites are right.",
        )  # fmt: skip
    R_s, R_a = ref.site_xmat[sid].reshape(3, 3), ref.site_xmat[site_a[1]].reshape(3, 3)
    dist = float(np.linalg.norm(ref.site_xpos[sid] - ref.site_xpos[site_a[1]]))
    angle = float(np.linalg.norm(twist_from_transform(R_s.T @ R_a, np.zeros(3), check=False)[:3]))
    if not _coincide(dist, angle, tol):
        raise model_error(
            element,
            f"its frame is {dist:.3g} m and {angle:.3g} rad away from the site '{site}' its record names (at qpos0)",
            "The site was moved without the element: place the element again at the site "
            '(mjflex.add_flexure(..., site=...) or mjflex.make_compliant), or drop "site" from its record.'
            if np.isfinite([dist, angle]).all()
            else _NONFINITE,
        )


def _inverse_inertia(model, bodies):
    """Largest inverse mass and inverse principal inertia of the non-world bodies (0 when massless)."""
    inv_m = inv_i = 0.0
    for b in bodies:
        if b > 0 and model.body_mass[b] > 0:
            inv_m = max(inv_m, 1.0 / float(model.body_mass[b]))
        if b > 0 and model.body_inertia[b].min() > 0:
            inv_i = max(inv_i, 1.0 / float(model.body_inertia[b].min()))
    return inv_m, inv_i


def _plugin_elements(model, all_sites):
    """``[(element, config text, site a, site b, record, instance)]`` of the model's mjflex.flexure instances."""
    ours = _native.plugin_instances(model)
    if not ours:
        return []
    attributes = _native.plugin_attributes()
    out = []
    for i in ours:
        element = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, i) or ""
        start = int(model.plugin_attradr[i])
        values = bytes(model.plugin_attr[start:]).split(b"\x00")[: len(attributes)]
        config = {a: v.decode("utf-8") for a, v in zip(attributes, values, strict=True)}
        try:
            record = schema.record_from_config(element, config)
        except ValueError as exc:
            problem = f"its plugin configuration is malformed: {str(exc).rstrip('.')}"
            raise model_error(element, problem, "Fix its <config> attributes (see mjflex.mj.schema).") from None
        text = schema.config_text(config)
        site_a, site_b = schema.config_sites(config, element, all_sites)
        out.append((element, text, site_a, site_b, record, i))
    return out


def derive(model) -> Tables:
    """Parse, check and lay out the elements of ``model``; raises :class:`ModelError`."""
    m = model
    all_sites = names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite)
    plugins = _plugin_elements(m, all_sites)
    claimed = {p[2] for p in plugins}
    found = [(e, text, a, b, None, -1) for e, text, a, b, _ in _records(m, {s for s in all_sites if s}, claimed)]
    twice = sorted({e for e, *_ in found} & {e for e, *_ in plugins})
    if twice:
        raise model_error(
            twice[0], "it is both a text record and an mjflex.flexure plugin instance (its forces would be added "
            "twice)", "Keep one of them (python -m mjflex convert writes either form).",
        )  # fmt: skip
    found += plugins
    n = len(found)
    elements = np.zeros(n, dtype=_native.ELEMENT_DTYPE)
    tolerance, chain, joined, records, sites, terms = np.zeros(n), [], {}, [], [], []
    ref = mujoco.MjData(m)
    ref.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, ref)
    for e, (element, data, site_a, site_b, rec, _) in enumerate(found):
        rec = parse(element, data) if rec is None else rec
        records.append(rec)
        sites.append((site_a, site_b))
        sa, sb = (
            _site_id(m, element, s, role, all_sites, {site_a, site_b})
            for s, role in ((site_a, "body A"), (site_b, "body B"))
        )
        ba, bb = int(m.site_bodyid[sa]), int(m.site_bodyid[sb])
        if ba == bb:
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, ba) or f"#{ba}"
            fix = "Put site a on one body and site b on the other (use 'world' to ground)."
            raise model_error(element, f"both sites are on body '{body}'", fix)
        R0, p0, dist, angle = rest_offset(ref, sa, sb)
        tolerance[e] = schema.COINCIDENCE_RTOL * max(_length_scale(m, sa, sb), 1e-9)
        _check_coincident(element, (site_a, site_b), dist, angle, tolerance[e])
        if rec.site is not None:
            _check_frame_site(m, ref, element, rec.site, (site_a, sa), tolerance[e])
        row = elements[e]
        row["site_a"], row["site_b"], row["body_a"], row["body_b"] = sa, sb, ba, bb
        row["method"] = validation.METHOD_CODES[rec.method]
        row["enabled"], row["viscous"] = rec.enabled, rec.viscous and rec.B is not None
        row["offset"] = not (np.array_equal(R0, np.eye(3)) and not p0.any())
        for body, side in ((ba, "a"), (bb, "b")):
            row[f"free_{side}"] = _free_dofadr(m, body)
            dofs = [] if row[f"free_{side}"] >= 0 else _dof_chain(m, body)
            row[f"chain_{side}0"], row[f"chain_{side}1"] = len(chain), len(chain) + len(dofs)
            chain.extend(dofs)
        K = schema.embed_planar(rec.K) if rec.planar else rec.K
        B = np.zeros((6, 6)) if rec.B is None else (schema.embed_planar(rec.B) if rec.planar else rec.B)
        row["K"], row["B"], row["R0"], row["p0"] = K.ravel(), B.ravel(), R0.ravel(), p0
        row["kstruct"], row["bstruct"] = matrix_structure(K), matrix_structure(B)
        row["inv_mass"], row["inv_inertia"] = _inverse_inertia(m, (ba, bb))
        row["stop_lo"], row["stop_hi"] = -np.inf, np.inf  # as the plugin's init lays out an element without stops
        if rec.stops:
            row["stops"] = 1
            row["stop_lo"], row["stop_hi"], row["stop_k"] = rec.stops.element_rows(rec.K)
        _native.prepare(m, elements, e)  # the derived fields exactly as the plugin's init computes them
        _lay_out_terms(row, rec.terms, terms)
        trees = [int(m.body_treeid[b]) for b in (ba, bb)]
        mocap = any(m.body_mocapid[b] >= 0 for b in (ba, bb))
        if trees[0] != trees[1] and (min(trees) >= 0 or mocap):
            joined.update({t: element for t in trees if t >= 0})
    return Tables(
        names=tuple(r[0] for r in found),
        texts={r[0]: r[1] for r in found},
        records=records,
        sites=sites,
        kinds=tuple(RECORD if r[5] < 0 else PLUGIN for r in found),
        instances=tuple(r[5] for r in found),
        elements=elements if n else np.zeros(1, dtype=_native.ELEMENT_DTYPE),
        chain=np.array(chain + [0], dtype=np.int32),  # never empty: a valid address
        tolerance=tolerance,
        joined_trees=joined,
        **_terms_table(terms),
    )


def matrix_structure(M: np.ndarray) -> int:
    """``_native.DIAGONAL``, ``ZERO`` or ``FULL`` for a 6x6 matrix (as ``mjfx_matrix_structure``)."""
    off = M[~np.eye(6, dtype=bool)]
    if off.any():
        return _native.FULL
    return _native.DIAGONAL if np.diagonal(M).any() else _native.ZERO


def _lay_out_terms(row, terms, tables):
    """Give element ``row`` the next rows of the terms' table (``tables``: the (exps, coefs) so far)."""
    lo = sum(len(c) for _, c in tables)
    row["terms_lo"] = row["terms_hi"] = lo
    if terms is None or len(terms) == 0:
        return
    exps = np.zeros((len(terms), _native.TERM_COLUMNS), dtype=np.int32)
    exps[:, : terms.exponents.shape[1]] = terms.exponents
    tables.append((exps, terms.coefficients))
    row["terms_hi"] = lo + len(terms)
    row["terms_top"] = int(terms.exponents.max())


def _terms_table(tables):
    """The terms of all elements as ``exps`` (M, 8) and ``coefs`` (M,); one zero row when there are none."""
    if not tables:
        return {"exps": np.zeros((1, _native.TERM_COLUMNS), dtype=np.int32), "coefs": np.zeros(1)}
    exps = np.ascontiguousarray(np.concatenate([e for e, _ in tables]), dtype=np.int32)
    return {"exps": exps, "coefs": np.ascontiguousarray(np.concatenate([c for _, c in tables]))}


class Touch(NamedTuple):
    """Two geoms in contact that an element makes suspicious (see :func:`contacts_at_rest`)."""

    element: str
    own: bool  # True: the element's own two bodies; False: a pair its un-welding exposed
    geom1: str
    geom2: str
    body1: str
    body2: str
    where: str  # "the reference configuration" or "keyframe 'name'"


def contacts_at_rest(model, tables: Tables) -> list[Touch]:
    """Contacts that MuJoCo finds at ``qpos0`` and at the keyframes and that an element makes suspicious.

    * ``own``: the element's two bodies touch (bodies welded to either count as it);
    * neighbour (``own=False``): the element's bodies sit in one kinematic tree, the joints
      between them un-weld the lower one, and two bodies touch whose pair MuJoCo's weld rules
      filtered in the rigid model (those joints removed; :func:`._contacts.rigid_weld`), e.g. a
      hand with the link before its parent. Explicit ``<pair>`` contacts are not neighbours.

    The check is MuJoCo's own collision detection (``mj_fwdPosition``) in the reference
    configuration and the first ``_contacts.MAX_KEYFRAMES`` keyframes, so contype/conaffinity,
    the parent filter, ``<exclude>``, ``<pair>``, margins and the contact disable flag count
    exactly as in a step; it costs one ``mj_fwdPosition`` per configuration plus a look-up per
    contact. One touch is returned per element for its own pair, and per element and body pair
    for neighbours. Geoms that only come into
    contact once the element deflects are not reported.
    """
    if not tables.names or model.ngeom < 2 or model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        return []
    weld, parent, filterparent = model.body_weldid, model.body_parentid, _contacts.filterparent(model)
    joined, rigid = {}, []
    for e, row in enumerate(tables.elements):
        joined.setdefault(frozenset((int(weld[row["body_a"]]), int(weld[row["body_b"]]))), tables.names[e])
        merged = _contacts.rigid_weld(model, row["body_a"], row["body_b"])
        if merged is not None:
            rigid.append((tables.names[e], merged))
    pairs = _contacts.explicit_pairs(model) if rigid else set()
    found, seen = [], set()
    for where, data in _contacts.configurations(model):
        for g1, g2 in zip(data.contact.geom1[: data.ncon], data.contact.geom2[: data.ncon], strict=True):
            if g1 < 0 or g2 < 0:  # a contact of a MuJoCo flex, not of two bodies' geoms
                continue
            b1, b2 = int(model.geom_bodyid[g1]), int(model.geom_bodyid[g2])
            owner = joined.get(frozenset((int(weld[b1]), int(weld[b2]))))
            if owner is not None:
                hits = [(owner, True)]
            elif frozenset((int(g1), int(g2))) in pairs:  # explicit pairs collide in the rigid model too
                continue
            else:
                hits = [(e, False) for e, w in rigid if _contacts.weld_filtered(w, parent, b1, b2, filterparent)]
            for element, own in hits:
                key = (element, True) if own else (element, False, frozenset((b1, b2)))
                if key not in seen:
                    seen.add(key)
                    names = [_contacts.geom_name(model, g) for g in (g1, g2)]
                    bodies = [_contacts.body_name(model, b) for b in (b1, b2)]
                    found.append(Touch(element, own, *names, *bodies, where))
    return found


STRUCTURE = ["site_a", "site_b", "body_a", "body_b", "free_a", "free_b", "chain_a0", "chain_a1", "chain_b0",
             "chain_b1"]  # fmt: skip


def difference(mine: Tables, other: Tables, mine_model, other_model) -> str | None:
    """What differs between the elements of two models (None: the same, so one table serves both)."""
    if (mine_model.nq, mine_model.nv, mine_model.nbody, mine_model.nsite) != (
        other_model.nq, other_model.nv, other_model.nbody, other_model.nsite,
    ):  # fmt: skip
        return "its sizes (nq, nv, nbody, nsite) differ"
    if mine.names != other.names:
        return f"its elements are {list(other.names)[:5]}, not {list(mine.names)[:5]}"
    for e, name in enumerate(mine.names):
        if mine.texts[name] != other.texts[name]:
            return f"the text record of flexure '{name}' differs"
        if mine.elements[STRUCTURE][e] != other.elements[STRUCTURE][e]:
            return f"flexure '{name}' joins other sites, bodies or dofs"
        moved = _rest_moved(mine, other, e)
        if moved:
            return f"the sites of flexure '{name}' moved by {moved}"
    if not (
        np.array_equal(mine.chain, other.chain) and np.array_equal(mine_model.body_rootid, other_model.body_rootid)
    ):
        return "its kinematic trees differ"
    return None


def _rest_moved(mine, other, e):
    R = mine.elements["R0"][e].reshape(3, 3).T @ other.elements["R0"][e].reshape(3, 3)
    dp = other.elements["p0"][e] - mine.elements["p0"][e]
    angle = float(np.linalg.norm(twist_from_transform(R, np.zeros(3), check=False)[:3]))
    dist = float(np.linalg.norm(dp))
    if not _coincide(dist, angle, mine.tolerance[e]):
        return f"{dist:.3g} m and {angle:.3g} rad"
    return None
