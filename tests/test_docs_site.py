"""What the documentation says against what the code does (issue 33 item 12): option lists, stale claims."""

import glob
import os
import re

from mjflex.app import cli

ROOT = os.path.join(os.path.dirname(__file__), "..")
PAGES = [os.path.join(ROOT, "README.md"), os.path.join(ROOT, "CONTRIBUTING.md"),
         *glob.glob(os.path.join(ROOT, "docs", "**", "*.md"), recursive=True)]  # fmt: skip
#: ``--option a|b|c`` as the pages write the choices of an option.
CHOICES = re.compile(r"(--[a-z][a-z-]*) ([\w.:]+(?:\|[\w.:]+)+)")


def _parser_choices():
    """``{option: choices}`` of every option of ``python -m mjflex`` that has a fixed set of choices."""
    out = {}
    parser = cli.build_parser()
    subparsers = next(a for a in parser._actions if a.choices and isinstance(a.choices, dict)).choices
    for sub in subparsers.values():
        for action in sub._actions:
            if action.choices:
                for option in action.option_strings:
                    out.setdefault(option, set()).update(map(str, action.choices))
    return out


def test_every_choice_list_in_the_pages_is_the_command_lines():
    """``--executor batch|pool|dask`` (1.0.0's command-line reference and sweep how-to) left out ``warp``: each
    ``--option a|b|c`` in the pages lists exactly the choices of the command line's option (or, for options that take
    any value, e.g. ``--device cpu|cuda:0``, examples of it)."""
    choices = _parser_choices()
    assert {"--executor", "--method", "--integrator", "--quality"} <= set(choices)
    found = []
    for page in PAGES:
        with open(page) as f:
            for number, line in enumerate(f, 1):
                for option, listed in CHOICES.findall(line):
                    if option in choices:
                        found.append(option)
                        where = f"{os.path.relpath(page, ROOT)}:{number}"
                        assert set(listed.split("|")) == choices[option], (where, option, listed, choices[option])
    assert found.count("--executor") >= 3, found  # the reference, the how-to and the README


def test_no_page_says_the_forces_are_computed_in_python():
    """Every force comes from the C library (no Python fallback); 1.0.0's troubleshooting page said a failed build
    made mjflex compute them in Python."""
    stale = re.compile(r"(computes?|computed) the forces in Python|forces (are )?computed in Python", re.IGNORECASE)
    for page in PAGES:
        with open(page) as f:
            text = " ".join(f.read().split())
        assert not stale.search(text), (page, stale.search(text))
