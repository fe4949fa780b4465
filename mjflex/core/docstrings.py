"""Docstrings that share text: a line ``{name}`` in a docstring stands for a shared part (the Parameters entries of
arguments several functions take, an example's set-up), filled in at import, so that ``help()``, the API pages and
doctest all read the whole text. The only helper of the package that is not numerical; it has no dependencies.
"""

import re
import textwrap

_PLACEHOLDER = re.compile(r"^([ \t]*)\{(\w+)\}\n", re.MULTILINE)


def filled_text(text, parts):
    """``text`` with each line ``{name}`` replaced by ``parts[name]``, indented as that line.

    Parameters
    ----------
    text : str
        A docstring.
    parts : dict
        The shared parts by name, each written without indentation (or with a common one, removed) and ending in a
        newline; a part may hold other parts' lines.

    Returns
    -------
    str
        The text with every part filled in.

    Raises
    ------
    ValueError
        A line ``{name}`` names no part (a typo would otherwise show in the rendered docs).

    Examples
    --------
    >>> from mjflex.core.docstrings import filled_text
    >>> parts = {"load": "wrench : array_like, shape (6,)\\n    [N m; N]\\n"}
    >>> print(filled_text("Parameters\\n    {load}\\nReturns", parts))
    Parameters
        wrench : array_like, shape (6,)
            [N m; N]
    Returns
    """

    def fill(match):
        indent, name = match.groups()
        if name not in parts:
            raise ValueError(f"docstring line {{{name}}}: no shared part {name!r} (the parts are {sorted(parts)})")
        return textwrap.indent(filled_text(textwrap.dedent(parts[name]), parts), indent)

    return _PLACEHOLDER.sub(fill, text)


def with_shared_docstring(parts):
    """A decorator that fills the shared ``parts`` into a function's or a class's docstring (:func:`filled_text`).

    Parameters
    ----------
    parts : dict
        The shared parts by name (:func:`filled_text`).

    Returns
    -------
    callable
        ``obj -> obj`` with its ``__doc__`` filled in (left None where docstrings are stripped: ``python -OO``).

    Examples
    --------
    >>> from mjflex.core.docstrings import with_shared_docstring
    >>> @with_shared_docstring({"unit": "[N m/rad]\\n"})
    ... def stiffness():
    ...     '''The stiffness, in
    ...     {unit}
    ...     '''
    >>> print(stiffness.__doc__.split("\\n")[1].strip())
    [N m/rad]
    """

    def fill(obj):
        if obj.__doc__ is not None:
            obj.__doc__ = filled_text(obj.__doc__, parts)
        return obj

    return fill
