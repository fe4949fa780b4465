"""MuJoCo's contact filtering by weld groups, and what un-welding a body exposes.

MuJoCo's collision detection (``engine_collision_driver.c``, ``filterBodyPair``) never collides
two bodies of one *weld group* (bodies with no joint between them), and, unless the
``filterparent`` flag is disabled, never collides two non-world weld groups of which one is the
parent of the other (the parent of a group is the group of its root body's parent). Explicit
``<pair>`` elements bypass both rules; ``<exclude>`` and contype/conaffinity apply on top.

Giving a welded body joints (to put a flexure element between it and its parent) splits its
weld group: the body and its welded descendants become a group of their own, so pairs the
rigid model filtered (the body with its grandparent's group, the parent's other jointed
children with the body, the body's jointed children with the old parent...) are collided
again. :func:`exposed_pairs` lists them from two compiled models, and :func:`rigid_weld`
reconstructs the rigid model's groups from the compliant one for the check of
:class:`mjflex.Flexures`.
"""

import mujoco
import numpy as np

#: Keyframes checked for contacts besides ``qpos0`` (the first ones of the model): each costs one
#: ``mj_fwdPosition``, so that building a provider stays cheap for models with many keyframes.
MAX_KEYFRAMES = 64


def weld_filtered(weld, parent, b1, b2, filterparent=True):
    """Whether MuJoCo's weld rules drop the body pair ``(b1, b2)`` (arrays broadcast).

    ``weld`` (nbody,): weld group (root body id) of each body; ``parent`` (nbody,): parent body id.
    Same group, or (both groups non-world and ``filterparent``) one group the parent of the other.
    """
    w1, w2 = weld[b1], weld[b2]
    p1, p2 = weld[parent[w1]], weld[parent[w2]]
    family = (w1 != 0) & (w2 != 0) & ((w1 == p2) | (w2 == p1))
    return (w1 == w2) | (bool(filterparent) & family)


def filterparent(model) -> bool:
    return not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT


def compatible_bodies(model) -> np.ndarray:
    """``(nbody, nbody)`` bool: some geom of one body may collide with some geom of the other by
    contype/conaffinity (MuJoCo's bitmask rule, either way round)."""
    n = model.nbody
    ok = np.zeros((n, n), dtype=bool)
    ct, ca, body = model.geom_contype, model.geom_conaffinity, model.geom_bodyid
    hit = ((ct[:, None] & ca[None, :]) != 0) | ((ct[None, :] & ca[:, None]) != 0)
    g1, g2 = np.nonzero(hit)
    ok[body[g1], body[g2]] = True
    return ok | ok.T


def excluded_bodies(model) -> set:
    """The body pairs of the model's ``<exclude>`` elements, as frozensets of body ids."""
    return {frozenset((int(s >> 16), int(s & 0xFFFF))) for s in model.exclude_signature}


def exposed_pairs(rigid, compliant):
    """Body pairs ``[(b1, b2)]`` (ids, ``b1 < b2``) that MuJoCo's weld rules filter in ``rigid`` but
    not in ``compliant`` (the same bodies, with joints added), whose geoms may collide by
    contype/conaffinity and which no ``<exclude>`` of ``compliant`` drops."""
    if rigid.nbody != compliant.nbody:
        raise ValueError("the two models must have the same bodies")
    b1, b2 = np.triu_indices(compliant.nbody, k=1)
    before = weld_filtered(rigid.body_weldid, rigid.body_parentid, b1, b2, filterparent(rigid))
    after = weld_filtered(compliant.body_weldid, compliant.body_parentid, b1, b2, filterparent(compliant))
    keep = before & ~after & compatible_bodies(compliant)[b1, b2]
    excluded = excluded_bodies(compliant)
    return [(int(i), int(j)) for i, j in zip(b1[keep], b2[keep], strict=True) if frozenset((i, j)) not in excluded]


def ancestors(model, body) -> list[int]:
    """``body`` and the bodies above it, up to the world (0)."""
    out = [body]
    while body > 0:
        body = int(model.body_parentid[body])
        out.append(body)
    return out


def rigid_weld(model, body_a, body_b) -> np.ndarray | None:
    """Weld groups of ``model`` with the joints between two bodies removed, or None.

    When one body is an ancestor of the other in the kinematic tree, the weld groups on the path
    from the lower body up to the upper one merge into the upper body's group (the rigid model an
    element between them replaces). None when neither is an ancestor of the other (different
    trees, or siblings: no weld to restore) or when they share a group already.
    """
    weld = np.asarray(model.body_weldid)
    a, b = int(body_a), int(body_b)
    if weld[a] == weld[b]:
        return None
    if a in ancestors(model, b):
        top, bottom = a, b
    elif b in ancestors(model, a):
        top, bottom = b, a
    else:
        return None
    groups, g = set(), int(weld[bottom])
    while g != weld[top]:
        groups.add(g)
        g = int(weld[model.body_parentid[g]])
    merged = weld.copy()
    merged[np.isin(weld, list(groups))] = weld[top]
    return merged


def configurations(model):
    """``(label, data)`` after ``mj_fwdPosition`` at ``qpos0`` and at the first ``MAX_KEYFRAMES`` keyframes."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    mujoco.mj_fwdPosition(model, data)
    yield "the reference configuration", data
    for k in range(min(model.nkey, MAX_KEYFRAMES)):
        mujoco.mj_resetDataKeyframe(model, data, k)
        mujoco.mj_fwdPosition(model, data)
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k)
        yield f"keyframe '{name}'" if name else f"keyframe {k}", data


def explicit_pairs(model) -> set:
    """The geom pairs of the model's ``<pair>`` elements, as frozensets of geom ids."""
    return {frozenset((int(g1), int(g2))) for g1, g2 in zip(model.pair_geom1, model.pair_geom2, strict=True)}


def body_name(model, body) -> str:
    return "world" if body == 0 else (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(body)) or f"#{body}")


def geom_name(model, geom) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(geom)) or f"#{geom}"


def neighbour_message(touches, joined):
    """The warning for bodies that touch because the joints under an element un-welded one of them.

    ``joined``: element -> the names of its two bodies."""
    t = touches[0]
    excludes = "".join(f'<exclude body1="{u.body1}" body2="{u.body2}"/>' for u in touches[:8])
    more = f" ({len(touches) - 1} more such pairs listed below)" if len(touches) > 1 else ""
    a, b = joined[t.element]
    return (
        f"mjflex: bodies '{t.body1}' and '{t.body2}' touch in {t.where} (geoms '{t.geom1}' and '{t.geom2}'), a "
        f"contact MuJoCo filtered while '{a}' and '{b}' were welded together: the joints between the bodies of "
        f"flexure '{t.element}' make separate weld groups of them, and MuJoCo's parent filter works on weld groups, "
        f"so they now collide with their grandparent and other neighbours{more}. A resting contact carries part of the "
        f"load and spoils the element's statics. Restore the filtering: <contact>{excludes}</contact> "
        "(mjflex.make_compliant writes these), or keep the contact on purpose. All: "
        + "; ".join(f"'{u.body1}'-'{u.body2}' in {u.where} (flexure '{u.element}')" for u in touches)
    )
