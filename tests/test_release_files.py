"""The files a release carries, and one version string everywhere.

The version is written once, as ``mjflex.__version__``: the installed distribution's metadata (what pip, the
wheel's file name and ``importlib.metadata`` say), ``pyproject.toml`` (which reads it), the docs (``release``
in ``docs/conf.py``) and ``CITATION.cff`` must agree with it.
"""

import ast
import importlib.metadata
import os
import re
import tomllib

import yaml

import mjflex

ROOT = os.path.join(os.path.dirname(__file__), "..")


def _read(name):
    with open(os.path.join(ROOT, name), encoding="utf-8") as f:
        return f.read()


def _pyproject():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        return tomllib.load(f)


def test_one_version_string():
    project = _pyproject()
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "mjflex.__version__"}
    assert re.fullmatch(r"\d+\.\d+\.\d+", mjflex.__version__)
    assert importlib.metadata.version("mjflex") == mjflex.__version__, "reinstall: pip install -e . --no-deps"
    conf = ast.parse(_read(os.path.join("docs", "conf.py")))
    release = [
        n for n in conf.body if isinstance(n, ast.Assign) and "release" in [getattr(t, "id", "") for t in n.targets]
    ]
    assert len(release) == 1 and ast.unparse(release[0].value) == "mjflex.__version__"
    assert yaml.safe_load(_read("CITATION.cff"))["version"] == mjflex.__version__


def test_license_is_the_apache_2_text_that_pyproject_declares():
    text = _read("LICENSE")
    assert text.lstrip().startswith("Apache License\n                           Version 2.0, January 2004")
    sections = re.findall(r"^\s+(\d)\. (\w[\w ]+)\.", text, re.M)
    assert [number for number, _ in sections] == [str(i) for i in range(1, 10)], sections
    assert "END OF TERMS AND CONDITIONS" in text and "APPENDIX: How to apply the Apache License" in text
    project = _pyproject()["project"]
    assert project["license"] == "Apache-2.0" and project["license-files"] == ["LICENSE"]
    assert importlib.metadata.metadata("mjflex")["License-Expression"] == "Apache-2.0"


def test_citation_names_the_software_and_the_paper_as_the_paper_states_it():
    """Only what the paper states: its title, author and affiliation; no venue, year or DOI."""
    citation = yaml.safe_load(_read("CITATION.cff"))
    assert citation["cff-version"] == "1.2.0" and citation["type"] == "software"
    assert citation["license"] == "Apache-2.0"
    (paper,) = citation["references"]
    assert paper["title"] == (
        "Some Applications of Screw Theory to Lumped-Parameter Modeling of Visco-Elastically Coupled Rigid Bodies"
    )
    assert paper["authors"] == [
        {
            "family-names": "Fasse",
            "given-names": "Ernest D.",
            "affiliation": "Dept. of Aerospace and Mechanical Engineering, The University of Arizona, Tucson, "
            "Arizona, USA",
        }
    ]
    invented = {"doi", "journal", "year", "date-published", "volume", "issue", "pages", "conference", "publisher"}
    assert not invented & set(paper), invented & set(paper)


def test_the_release_carries_its_documents():
    project = _pyproject()["project"]
    assert project["urls"] and all(u.startswith("https://") for u in project["urls"].values())
    assert "Programming Language :: Python :: 3.13" in project["classifiers"]
    changelog = _read("CHANGELOG.md")
    # the newest section is this version's (or work towards it, "Unreleased")
    newest = re.search(r"^## (.+)$", changelog, re.M).group(1)
    assert changelog.startswith("# Changelog") and newest.split()[0] in (mjflex.__version__, "Unreleased"), newest
    contributing = _read("CONTRIBUTING.md")
    for topic in ("## Test", "## Documentation", "## Benchmarks", "## The native library", "### The vector lanes",
                  "## Adding an element feature end to end", "## Releases"):  # fmt: skip
        assert topic in contributing, topic
    install = _read(os.path.join("docs", "install.md"))
    assert "## Supported platforms" in install
    for platform in ("Linux x86-64", "Linux aarch64", "macOS", "Windows"):
        assert f"| {platform} |" in install, platform
