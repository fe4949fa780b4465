"""Names: close-name suggestions for every "not found" message of the MuJoCo layer (one wording everywhere), and
the names of an element's text record and sites (:func:`match_record`; the convention: :mod:`mjflex.mjcf.schema`).

A name that is not found gets the close names (:func:`close_names`: the same letters and digits
in any case and with any separators, difflib's close matches, names that contain it), never the
first few of a long list; a name of another kind of the spec (a joint's name where a body is
expected) is said to be that (:func:`spec_hint`).
"""

import difflib
import re

from .schema import PREFIX, SITE_A_SUFFIX, SITE_B_SUFFIX, SITE_SEPARATORS

#: Kinds of named MjSpec elements: the spec's look-up method and list (``spec.body(name)``, ``spec.bodies``).
PLURALS = {"body": "bodies", "joint": "joints", "site": "sites", "geom": "geoms"}
_LISTED = 10  # a short list of candidates is given whole when none is close


def _key(name) -> str:
    """``name`` in lower case without separators: ``"L4_L5-site"`` -> ``"l4l5site"``."""
    return re.sub(r"[^0-9a-z]", "", str(name).lower())


def close_names(name, candidates, n=3) -> list[str]:
    """Up to ``n`` of ``candidates`` close to ``name``, closest first; empty when none is.

    Close: equal letters and digits (any case, any separators), else difflib's close matches of
    those keys (ratio >= 0.6), else the candidates whose key contains the name's (or is contained,
    3 characters or more).
    """
    candidates = [c for c in dict.fromkeys(candidates) if c]
    key = _key(name)
    keys = {c: _key(c) for c in candidates}
    same = [c for c in candidates if keys[c] == key and key]
    if same:
        return same[:n]
    ratio = {c: difflib.SequenceMatcher(None, key, keys[c]).ratio() for c in candidates}
    close = sorted((c for c in candidates if ratio[c] >= 0.6), key=lambda c: -ratio[c])
    if not close and key:
        close = sorted((c for c in candidates if key in keys[c] or (len(keys[c]) >= 3 and keys[c] in key)),
                       key=lambda c: -ratio[c])  # fmt: skip
    return close[:n]


def suggestion(name, candidates, what="names") -> str:
    """``"; did you mean ['a', 'b']?"`` for the close names of ``name``, else the candidates if they are few.

    ``what``: what the candidates are (e.g. ``"bodies"``). Many candidates and none close: their
    number, not the first few. Empty when there are none.
    """
    candidates = [c for c in dict.fromkeys(candidates) if c]
    close = close_names(name, candidates)
    if close:
        return f"; did you mean {close}?"
    if not candidates:
        return ""
    if len(candidates) <= _LISTED:
        return f" (its {what}: {candidates})"
    return f" (none of its {len(candidates)} {what} has a close name)"


def other_kind(spec, name, kind) -> str:
    """``"; that is a joint of body 'L5', not a body"`` when ``name`` names an element of ``spec`` of another kind than
    ``kind`` (``"body"``, ``"site"``, ...); empty otherwise."""
    if not isinstance(name, str) or not name:
        return ""
    for other in PLURALS:
        found = None if other == kind else getattr(spec, other)(name)
        if found is not None:
            if other == "body":
                return f"; that is a body, not a {kind}"
            owner = getattr(found.parent, "name", "") or "world"
            return f"; that is a {other} of body {owner!r}, not a {kind}"
    return ""


def spec_hint(spec, name, kind) -> str:
    """The hint for ``name``, which is not a ``kind`` of ``spec``: what it is instead, or the close names of that kind.

    Parameters
    ----------
    spec : mujoco.MjSpec
    name : str
        The name given.
    kind : {"body", "joint", "site", "geom"}
        What was expected.

    Examples
    --------
    >>> import mujoco
    >>> spec = mujoco.MjSpec.from_string('<mujoco><worldbody><body name="arm"><joint name="elbow"/>'
    ...                                  '<geom size="0.1"/><site name="tip"/></body></worldbody></mujoco>')
    >>> spec_hint(spec, "elbow", "body")
    "; that is a joint of body 'arm', not a body"
    >>> spec_hint(spec, "TIP", "site")
    "; did you mean ['tip']?"
    """
    return other_kind(spec, name, kind) or suggestion(
        name, [e.name for e in getattr(spec, PLURALS[kind]) if e.name], PLURALS[kind]
    )


def site_names(element: str) -> tuple[str, str]:
    """The canonical site names ``E/a``, ``E/b`` of element ``E`` (what ``add_flexure`` writes)."""
    return element + SITE_A_SUFFIX, element + SITE_B_SUFFIX


def match_record(text_name: str, sites) -> tuple[str, str, str, bool] | None:
    """The element a text record describes: ``(element, site a, site b, found)``, or None.

    ``text_name`` is ``P + "mjflex:" + E + S`` (``P``, ``S``: prefix and suffix added by
    ``MjSpec.attach`` or dm_control, usually empty); ``sites`` is the set of the model's site
    names. The sites are ``P + E + sep + "a" + S`` and ``... "b" + S`` for a separator in
    ``SITE_SEPARATORS``; the longest ``E`` whose two sites exist wins. When none exist,
    ``found`` is False and the canonical names (empty suffix, ``/``) are returned for the error.
    Raises ValueError when both spellings of one element exist.
    """
    i = text_name.find(PREFIX)
    if i < 0:
        return None
    head, rest = text_name[:i], text_name[i + len(PREFIX) :]
    for j in range(len(rest), -1, -1):
        element, tail = rest[:j], rest[j:]
        both = [
            (head + element + sep + "a" + tail, head + element + sep + "b" + tail)
            for sep in SITE_SEPARATORS
            if head + element + sep + "a" + tail in sites and head + element + sep + "b" + tail in sites
        ]
        if len(both) > 1:
            raise ValueError(f"both {both[0]} and {both[1]} exist; keep one spelling of the element's sites")
        if both:
            return head + element + tail, both[0][0], both[0][1], True
    return head + rest, head + rest + SITE_A_SUFFIX, head + rest + SITE_B_SUFFIX, False


def near_miss(text_name: str) -> bool:
    """Whether a text name without ``mjflex:`` looks like a misspelt record (``mjflx:``, ``MJFLEX:``, ``mjflex-``)."""
    if PREFIX in text_name:
        return False
    lower = text_name.lower()
    if "mjflex" in lower:
        return True
    windows = {lower[i : i + n] for n in (6, 7, 8) for i in range(max(len(lower) - n + 1, 1))}
    return any(difflib.SequenceMatcher(None, w, PREFIX).ratio() >= 0.8 for w in windows)


def orphan_site_pairs(sites, elements_sites) -> list[str]:
    """Names ``E`` with sites ``E/a`` and ``E/b`` (or ``E.a``, ``E.b``) that no record claims."""
    out = []
    for name in sorted(sites):
        for sep in SITE_SEPARATORS:
            if name.endswith(sep + "a") and name[:-1] + "b" in sites:
                if name not in elements_sites:
                    out.append(name[: -len(sep) - 1])
    return out
