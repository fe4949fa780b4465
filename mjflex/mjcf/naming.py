"""Close-name suggestions for every "not found" message of the MuJoCo layer (one wording everywhere).

A name that is not found gets the close names (:func:`close_names`: the same letters and digits
in any case and with any separators, difflib's close matches, names that contain it), never the
first few of a long list; a name of another kind of the spec (a joint's name where a body is
expected) is said to be that (:func:`spec_hint`).
"""

import difflib
import re

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
