"""What :class:`mjflex.Flexures` reads from a model: its elements, parsed, checked and laid out
in the element table that the C loop reads (one ``mjflex.native.library.ELEMENT_DTYPE`` row each).

An element is written in a model file either as a text record with two sites
(:mod:`mjflex.mjcf.schema`) or as an instance of the engine plugin ``mjflex.flexure``
(:mod:`mjflex.mjcf.config`); both give the same table row, so every analysis works on both.

The set-up of an element exists once, in C (``mjflex/native/instances.c``, ``mjfx_read_element``):
its configuration's checks, its sites on two bodies, the rest offset and the coincidence checks,
the frame site, the derived fields, inverse inertias and dof chains. The plugin's ``init`` runs
it on its instances; :func:`derive` runs it on every element of a model (``library.read_table``),
once: a text record is found here by its sites' names and its JSON given to C as the configuration
it is equal to (:func:`schema.config_from_payload`), and each element's record is made from what C
read (:func:`schema.record_from_values`). So a check has one message, in the words of the element's
form, and a record and a plugin instance of one element lay out the same row.

:func:`derive` is the single place where a model is read; the provider runs it once at
construction, and again on a model it is asked to serve (a copy) to check that the copy holds
the same elements in the same places.
"""

import hashlib
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from ..mjcf import naming, schema
from ..mjcf.config import config_sites, config_text
from ..mjcf.schema import PLUGIN, RECORD
from ..native import library
from . import contacts


class ModelError(ValueError):
    """A flexure element of a model is malformed; the message names the element and the fix."""


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


def _text_records(model, site_ids, claimed_sites=()):
    """``[(element, data, site a, site b, found)]`` of the model's records; warns about near misses."""
    out = []
    for i, tname in enumerate(names(model, mujoco.mjtObj.mjOBJ_TEXT, model.ntext)):
        try:
            match = naming.match_record(tname, site_ids)
        except ValueError as exc:
            raise ModelError(f"flexure record '{tname}': {exc}") from None
        if match is None:
            if naming.near_miss(tname):
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
    for element in naming.orphan_site_pairs(site_ids, claimed):
        warnings.warn(
            f"mjflex: sites of an element '{element}' have no text record '{schema.PREFIX}{element}' and no "
            f"{schema.PLUGIN_NAME} instance: the element is not simulated. Add it (mjflex.add_flexure writes both), "
            "or rename the sites. A model composed with MjSpec.attach or copied with MjSpec.copy loses the plugin "
            "instances no body references (MuJoCo 4.0): use mjflex.attach / mjflex.copy_spec",
            UserWarning,
            stacklevel=4,
        )
    return out


def _record_strings(element, data, site_a, site_b):
    """The configuration strings (in the table's order) a text record's JSON is equal to; ModelError otherwise."""
    try:
        config = schema.record_config(element, data) | {"site_a": site_a, "site_b": site_b}
    except ValueError as exc:  # what only JSON can get wrong (the values' rules: C's, in read_table)
        raise ModelError(f"flexure '{element}': text record '{schema.PREFIX}{element}' is malformed: {exc}") from None
    return [config.get(a.key, "") for a in schema.attributes()]


def _site_id(model, element, name, role, all_sites, others):
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    if sid < 0:
        close = naming.close_names(name, [s for s in all_sites if s not in others])
        hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise ModelError(f"flexure '{element}': site '{name}' not found. Add <site name=\"{name}\"/> at the element "
                         f"frame ({role}) or rename the existing site.{hint}")  # fmt: skip
    return sid


def _plugin_elements(model, all_sites):
    """``[(element, config text, site a, site b, strings)]`` of the model's mjflex.flexure instances, in order."""
    keys = [a.key for a in schema.attributes()]
    out = []
    for i in library.plugin_instances(model):
        element = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, i) or ""
        start = int(model.plugin_attradr[i])
        strings = [v.decode("utf-8") for v in bytes(model.plugin_attr[start:]).split(b"\x00")[: len(keys)]]
        config = dict(zip(keys, strings, strict=True))
        site_a, site_b = config_sites(config, element, all_sites)
        out.append((element, config_text(config), site_a, site_b, strings))
    return out


def derive(model) -> Tables:
    """Parse, check and lay out the elements of ``model``; raises :class:`ModelError`."""
    m = model
    all_sites = names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite)
    plugins = _plugin_elements(m, all_sites)
    found, configs = [], []
    for element, data, site_a, site_b, _ in _text_records(m, {s for s in all_sites if s}, {p[2] for p in plugins}):
        strings = _record_strings(element, data, site_a, site_b)
        for s, role in ((site_a, "body A"), (site_b, "body B")):
            _site_id(m, element, s, role, all_sites, {site_a, site_b})
        found.append((element, data, site_a, site_b, strings))
        configs.append((element, strings))
    try:
        ref = mujoco.MjData(m)  # runs the plugin instances' init, which may refuse a model edited in place
    except mujoco.FatalError as exc:
        raise ModelError(f"its mjflex.flexure instances cannot be read ({exc}; MuJoCo's warning says why)") from None
    try:
        elements, chain, exps, coefs, instances, values = library.read_table(m, ref, configs)
    except ValueError as exc:
        raise ModelError(str(exc)) from None
    found += plugins
    found = [(*f[:4], schema.record_from_values(f[0], f[4], *v)) for f, v in zip(found, values, strict=True)]
    joined = {}
    for e, row in enumerate(elements[: len(found)]):
        ba, bb = int(row["body_a"]), int(row["body_b"])
        trees = [int(m.body_treeid[b]) for b in (ba, bb)]
        mocap = any(m.body_mocapid[b] >= 0 for b in (ba, bb))
        if trees[0] != trees[1] and (min(trees) >= 0 or mocap):
            joined.update({t: found[e][0] for t in trees if t >= 0})
    return Tables(
        names=tuple(r[0] for r in found),
        texts={r[0]: r[1] for r in found},
        records=[r[4] for r in found],
        sites=[(r[2], r[3]) for r in found],
        kinds=tuple(RECORD if i < 0 else PLUGIN for i in instances),
        instances=instances,
        elements=elements,
        chain=chain,
        joined_trees=joined,
        exps=exps,
        coefs=coefs,
    )


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
    configuration and the first ``contacts.MAX_KEYFRAMES`` keyframes, so contype/conaffinity,
    the parent filter, ``<exclude>``, ``<pair>``, margins and the contact disable flag count
    exactly as in a step; it costs one ``mj_fwdPosition`` per configuration plus a look-up per
    contact. One touch is returned per element for its own pair, and per element and body pair
    for neighbours. Geoms that only come into
    contact once the element deflects are not reported.
    """
    if not tables.names or model.ngeom < 2 or model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        return []
    weld, parent, filterparent = model.body_weldid, model.body_parentid, contacts.filterparent(model)
    joined, rigid = {}, []
    for e, row in enumerate(tables.elements):
        joined.setdefault(frozenset((int(weld[row["body_a"]]), int(weld[row["body_b"]]))), tables.names[e])
        merged = contacts.rigid_weld(model, row["body_a"], row["body_b"])
        if merged is not None:
            rigid.append((tables.names[e], merged))
    pairs = contacts.explicit_pairs(model) if rigid else set()
    found, seen = [], set()
    for where, data in contacts.configurations(model):
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
                hits = [(e, False) for e, w in rigid if contacts.weld_filtered(w, parent, b1, b2, filterparent)]
            for element, own in hits:
                key = (element, True) if own else (element, False, frozenset((b1, b2)))
                if key not in seen:
                    seen.add(key)
                    names = [contacts.geom_name(model, g) for g in (g1, g2)]
                    bodies = [contacts.body_name(model, b) for b in (b1, b2)]
                    found.append(Touch(element, own, *names, *bodies, where))
    return found


def contact_warnings(model, tables: Tables) -> list[str]:
    """The warnings about elements whose bodies touch, or touch neighbours they were welded away from
    (:func:`contacts_at_rest`): one for the elements' own pairs, one for the neighbours."""
    touching, out, index = contacts_at_rest(model, tables), [], {name: e for e, name in enumerate(tables.names)}

    def bodies(element):
        return [contacts.body_name(model, b) for b in tables.elements[index[element]][["body_a", "body_b"]].tolist()]

    own = [t for t in touching if t.own]
    if own:
        t, (a, b) = own[0], bodies(own[0].element)
        more = f" (and {len(own) - 1} more elements: {', '.join(t[0] for t in own[1:4])}...)"
        out.append(
            f"mjflex: the bodies '{a}' and '{b}' joined by flexure '{t.element}'{more if len(own) > 1 else ''} "
            f"are in contact in {t.where} (geoms '{t.geom1}' and '{t.geom2}'): MuJoCo's contact pushes them "
            "apart while the element holds them together, which usually diverges. Exclude the pair: "
            f'<contact><exclude body1="{a}" body2="{b}"/></contact> (mjflex.add_flexure does this by default), '
            "or give the geoms contype/conaffinity that cannot collide."
        )
    neighbours = [t for t in touching if not t.own]
    if neighbours:
        out.append(contacts.neighbour_message(neighbours, {t.element: bodies(t.element) for t in neighbours}))
    return out


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
        same, dist, angle = library.offsets_coincide(mine_model, mine.elements[e : e + 1], other.elements[e : e + 1])
        if not same:
            return f"the sites of flexure '{name}' moved by {dist:.3g} m and {angle:.3g} rad"
    if not (
        np.array_equal(mine.chain, other.chain) and np.array_equal(mine_model.body_rootid, other_model.body_rootid)
    ):
        return "its kinematic trees differ"
    return None
