"""Rebuild a model's free bodies as kinematic trees: the shared machinery of the joint variants.

Flexure models (mjflex's convention) are free-jointed bodies coupled by elements. A variant
that replaces elements by joints (fidelity reduction, pseudo-rigid-body and bushing models)
nests each body under its neighbour in a spanning forest of the element graph: a tree edge
becomes the child body's joints at the element, a rigid edge a jointless child (the two bodies
move as one), and the edges left over close loops (the caller decides how: equality
constraints, or the element kept as it is).

The rebuild works on the model file (``MjSpec.to_xml``) so that everything else in it (geoms,
sites, assets, actuators, sensors) travels unchanged; moved bodies get their reference pose
relative to the new parent, computed from the compiled source at ``qpos0``.
"""

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..mjcf.spec import compile_spec
from .variant import body_names, identity_body_map, reference_poses

WORLD = "world"


@dataclass
class Joint:
    """A joint that replaces one compliant direction of an element.

    ``axis`` (unit) and ``point`` (a point on the axis, [m]) are in world coordinates at the
    reference configuration; ``stiffness`` [N m/rad or N/m] and ``damping`` [N m s/rad or N s/m].
    """

    kind: str  # "hinge" | "slide"
    label: str
    axis: np.ndarray
    point: np.ndarray
    stiffness: float
    damping: float


@dataclass
class Link:
    """An element seen as an edge between two bodies; ``joints`` empty means rigid."""

    element: str
    body_a: str
    body_b: str
    sites: tuple = ()  # names of the element's sites a and b
    joints: list = field(default_factory=list)
    info: dict = field(default_factory=dict)  # free for the caller (e.g. its principal directions)

    def other(self, body):
        return self.body_b if body == self.body_a else self.body_a


def joints_of(d, soft, damping=True):
    """Joints in the principal directions ``soft`` of an element (``d``: its
    :class:`~mjflex.analysis.directions.Directions`), with their stiffness and (``damping``) their damping."""
    return [Joint("hinge" if i < 3 else "slide", d.labels[i], d.axes_world[i], d.centre_world, float(d.k[i]),
                  float(d.b[i]) if damping else 0.0) for i in soft]  # fmt: skip


def link_of(d, names, joints):
    """The :class:`Link` of an element (``d``: its principal directions; ``names``: the body names by id)."""
    return Link(d.element, *(names[b] if b else WORLD for b in (d.body_a, d.body_b)), d.sites, joints=joints)


def numbers(v):
    """A number or an array as MJCF text, every digit kept."""
    return " ".join(f"{float(x):.17g}" for x in np.atleast_1d(v))


def retired_sites(element):
    """Names given to the sites of an element replaced by joints or constraints: ``E:a``, ``E:b``."""
    return f"{element}:a", f"{element}:b"


def free_world_bodies(model) -> set[str]:
    """Named bodies that are children of the world with exactly one joint, a free joint."""
    out = set()
    for b, name in enumerate(body_names(model)):
        if b and name and model.body_parentid[b] == 0 and model.body_jntnum[b] == 1:
            if model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE:
                out.add(name)
    return out


def spanning_forest(links, masses, *, fewest_joints=False, attached=()):
    """Split ``links`` into tree edges and loop closers.

    A spanning forest (Kruskal) weighted by the number of joints. By default a *maximum* one,
    so that links that are hardest to close as a loop (several joints) become tree edges and
    rigid or one-joint links are left to close loops by equality constraints (what the native
    builders need: they have no element to fall back on). With ``fewest_joints`` a *minimum*
    one: the trees carry the fewest joints, so the model has the fewest degrees of freedom
    (what :func:`mjflex.reduce` wants: a loop it cannot close by a constraint keeps its element).
    The minimum also makes the degrees of freedom monotone: with fewer joints per link, or more
    links, the minimum can only fall. Ties keep the order of ``links``. Each component is rooted
    at the world if it touches it, else at its heaviest body. Bodies in ``attached`` (those of the
    model's own kinematic trees) already hang from the world: a link between two of them closes a
    loop, and a free body linked to one is nested under it.

    Returns
    -------
    edges : list of (parent, child, Link)
        In breadth-first order from the roots (parents before children).
    closers : list of Link
    roots : list of str
    """
    parent = {}

    def find(x):
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for body in attached:
        parent[find(body)] = find(WORLD)
    sign = 1 if fewest_joints else -1
    order = sorted(range(len(links)), key=lambda i: sign * len(links[i].joints))
    tree, closers = [], []
    for i in order:
        link = links[i]
        ra, rb = find(link.body_a), find(link.body_b)
        if ra == rb:
            closers.append(link)
        else:
            parent[ra] = rb
            tree.append(link)
    adjacency = {}
    for link in tree:
        adjacency.setdefault(link.body_a, []).append(link)
        adjacency.setdefault(link.body_b, []).append(link)
    components = {}
    for body in adjacency:
        components.setdefault(find(body), []).append(body)
    roots = []
    for members in components.values():
        inside = WORLD in members or any(b in attached for b in members)
        roots.append(WORLD if inside else max(members, key=lambda b: (masses.get(b, 0.0), b)))
    edges, seen = [], set(roots) | set(attached)
    frontier = list(roots) + sorted(b for b in attached if b in adjacency)
    while frontier:
        nxt = []
        for body in frontier:
            for link in adjacency.get(body, []):
                child = link.other(body)
                if child not in seen:
                    seen.add(child)
                    edges.append((body, child, link))
                    nxt.append(child)
        frontier = nxt
    closers.sort(key=lambda link: links.index(link))
    return edges, closers, roots


class TreeXml:
    """The source's model file as an element tree, with the edits the joint variants need."""

    def __init__(self, spec, source_model):
        self.root = ET.fromstring(spec.to_xml())
        self.model = source_model
        self.xpos, self.xmat = reference_poses(source_model)
        self.index = {n: i for i, n in enumerate(body_names(source_model))}
        self.worldbody = self.root.find("worldbody")
        self.parent_of = {c: p for p in self.root.iter() for c in p}
        self.bodies = {b.get("name"): b for b in self.worldbody.iter("body") if b.get("name")}
        self._drop_keyframes()
        self._exact_inertias()
        for t in self.root.iter("text"):  # the file writes records as CDATA, which ElementTree does not keep
            if t.text and t.text.strip():
                t.set("data", t.text)
                t.text = None

    def _drop_keyframes(self):
        """Keyframes no longer fit the new qpos layout; the builders convert them afterwards."""
        for key in self.root.findall("keyframe"):
            self.root.remove(key)
        for size in self.root.findall("size"):
            size.attrib.pop("nkey", None)

    def _exact_inertias(self):
        """Write every named body's compiled inertia with all its digits.

        ``MjSpec.to_xml`` writes geom sizes and poses with 6 significant digits, which would
        change the inertias derived from geoms by ~1e-6; explicit inertials keep the physics
        of the variant's bodies identical to the source's.
        """
        for compiler in self.root.findall("compiler"):
            if compiler.get("inertiafromgeom") == "true":
                compiler.set("inertiafromgeom", "auto")
        m = self.model
        for name, el in self.bodies.items():
            i = self.index[name]
            for old in el.findall("inertial"):
                el.remove(old)
            attrs = {"pos": numbers(m.body_ipos[i]), "quat": numbers(m.body_iquat[i]), "mass": numbers(m.body_mass[i]),
                     "diaginertia": numbers(m.body_inertia[i])}  # fmt: skip
            el.insert(0, ET.Element("inertial", attrs))

    def pose(self, body):
        """Reference pose ``(R_WB, p_WB)`` of a source body (the world for ``"world"``)."""
        if body == WORLD:
            return np.eye(3), np.zeros(3)
        i = self.index[body]
        return self.xmat[i], self.xpos[i]

    def _remove_free_joint(self, body_el, name):
        for child in list(body_el):
            if child.tag == "freejoint" or (child.tag == "joint" and child.get("type") == "free"):
                body_el.remove(child)
                return
        raise ValueError(f"body {name!r} has no free joint written in the model file; cannot re-joint it")

    def nest(self, parent, child, joints, prefix):
        """Move body ``child`` under ``parent`` (``"world"``: stays) with ``joints`` instead of its free joint."""
        el = self.bodies[child]
        self._remove_free_joint(el, child)
        R_WP, p_WP = self.pose(parent)
        R_WC, p_WC = self.pose(child)
        if parent != WORLD:
            self.parent_of[el].remove(el)
            self.bodies[parent].append(el)
            self.parent_of[el] = self.bodies[parent]
        for key in ("pos", "quat", "euler", "axisangle", "xyaxes", "zaxis"):
            el.attrib.pop(key, None)
        if parent != WORLD:
            el.attrib.pop("sleep", None)  # MuJoCo allows a sleep policy on tree roots only
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, np.ascontiguousarray(R_WP.T @ R_WC).ravel())
        el.set("pos", numbers(R_WP.T @ (p_WC - p_WP)))
        el.set("quat", numbers(q))
        self.insert_joints(child, joints, prefix)

    def insert_joints(self, body, joints, prefix):
        """Put ``joints`` (:class:`Joint`, world coordinates) first in ``body``, named ``<prefix>:<label>``."""
        R_WB, p_WB = self.pose(body)
        for k, j in enumerate(joints):
            attrs = {
                "name": f"{prefix}:{j.label}", "type": j.kind, "pos": numbers(R_WB.T @ (j.point - p_WB)),
                "axis": numbers(R_WB.T @ j.axis), "stiffness": numbers(j.stiffness), "damping": numbers(j.damping),
                "springref": "0", "ref": "0", "armature": "0", "frictionloss": "0", "limited": "false",
            }  # fmt: skip
            self.bodies[body].insert(k, ET.Element("joint", attrs))

    def planar_root(self, body, n):
        """Replace the free joint of ``body`` by planar joints: two slides normal to ``n``, a hinge about it."""
        self._remove_free_joint(self.bodies[body], body)
        p_WB = self.pose(body)[1]
        e1 = np.linalg.svd(np.outer(n, n))[0][:, 1]
        axes = (("x", "slide", e1), ("y", "slide", np.cross(n, e1)), ("rz", "hinge", n))
        joints = [Joint(kind, f"plane_{label}", axis, p_WB, 0.0, 0.0) for label, kind, axis in axes]
        self.insert_joints(body, joints, body)

    def rotate_sites(self, sites, R_EF):
        """Turn both sites of an element by ``R_EF`` (element coordinates), keeping their origins."""
        for name in sites:
            sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
            R_BS = np.empty(9)
            mujoco.mju_quat2Mat(R_BS, self.model.site_quat[sid])
            q = np.empty(4)
            mujoco.mju_mat2Quat(q, np.ascontiguousarray(R_BS.reshape(3, 3) @ R_EF).ravel())
            for site in self.root.iter("site"):
                if site.get("name") == name:
                    for key in ("quat", "euler", "axisangle", "xyaxes", "zaxis"):
                        site.attrib.pop(key, None)
                    site.set("quat", numbers(q))

    def add(self, tag, kind, **attrs):
        """Add ``<tag><kind .../></tag>``, e.g. an equality constraint or a tendon; returns the element."""
        section = self.root.find(tag)
        if section is None:
            section = ET.SubElement(self.root, tag)
        return ET.SubElement(section, kind, {k: str(v) for k, v in attrs.items()})

    def text(self, element):
        """``(custom section, text element)`` of an element's record (its current data: ``.get("data")``)."""
        for custom in self.root.findall("custom"):
            for t in custom.findall("text"):
                if t.get("name") == "mjflex:" + element:
                    return custom, t
        raise KeyError(f"no text record for flexure {element!r}")

    def drop_element(self, element, sites=()):
        """Remove the element's record; its sites stay, renamed by :func:`retired_sites` (they mark the frame).

        Returns the sites' new names (the provider warns about ``E/a``, ``E/b`` sites without a record).
        """
        custom, t = self.text(element)
        custom.remove(t)
        new = retired_sites(element)
        for old, name in zip(sites, new, strict=False):
            for site in self.root.iter("site"):
                if site.get("name") == old:
                    site.set("name", name)
        return new

    def rewrite_element(self, element, data):
        _, t = self.text(element)
        t.text = None
        t.set("data", data)

    def compile(self, source_spec):
        """Spec and model of the edited file."""
        spec = mujoco.MjSpec.from_string(ET.tostring(self.root, encoding="unicode"))
        spec.modelfiledir = source_spec.modelfiledir
        return spec, compile_spec(spec, why=None)


def merged_body_map(variant_model, source_model):
    """``body_map`` when every named source body survives by name (jointless children included)."""
    out, names = identity_body_map(source_model), set(body_names(variant_model))
    for name in out:
        if name not in names:
            raise ValueError(f"source body {name!r} is missing from the variant")
    return out
