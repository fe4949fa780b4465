"""Close-name suggestions for every "not found" message of the MuJoCo layer (one wording everywhere)."""

import difflib


def suggestion(name, candidates, what="names") -> str:
    """``"; did you mean ['a', 'b']?"`` for the close matches of ``name``, else a short list of ``candidates``.

    ``what``: what the candidates are, for the list (e.g. ``"bodies"``). Empty when there are none.
    """
    candidates = [c for c in dict.fromkeys(candidates) if c]
    close = difflib.get_close_matches(str(name), candidates, n=3)
    if close:
        return f"; did you mean {close}?"
    if not candidates:
        return ""
    more = f" ... ({len(candidates)} in all)" if len(candidates) > 10 else ""
    return f" (its {what}: {candidates[:10]}{more})"
