"""Fenced code blocks of Markdown pages (README.md and docs/), and how the docs tests run them.

A block is ```` ```python ```` or ```` ```bash ```` (also ``sh``, ``shell``, ``console``); other
languages (``xml``, ``text``, none) are data or output, not programs. Every program block runs
in CI unless the line just above its fence marks it::

    <!-- not-run: REASON -->

with a reason (installs from the network, needs a cluster, takes minutes, ...). A page's python
blocks run in order as one script (later blocks use earlier names); a bash block runs line by
line, and an unmarked bash block may only call ``python -m mjflex``. Both run in a temporary
folder holding a copy of the repository's ``models/``, so paths like ``models/two_body.xml``
work as they do from the repository root.

A block passes when it exits with status 0 *and* what it printed is a result (:func:`output_problems`):
no warning printed by MuJoCo (``mju_warning``: a line ``WARNING: ...`` and an entry in its log
``MUJOCO_LOG.TXT``, which is how a diverged run shows: "Nan, Inf or huge value in QACC"), no warning
printed by Python (mjflex's, or any library's: ``file:line: SomeWarning: ...``), and no ``nan`` or
``inf`` among the printed numbers. A page that shows a warning on purpose catches it
(``warnings.catch_warnings(record=True)``, ``mujoco.set_mju_user_warning``) and prints what it means.

A comment line right below a ``print(`` line, at its indentation, says what that call prints
(:func:`printed_claims`): the output must hold such a line, the same words and each number within
one unit of the last digit the comment shows (:func:`claim_problems`), so the numbers a reader
sees beside the code are what it prints.

A python block that prints is followed by what it prints: a block of language ``output`` right after
it (only blank lines between), which the site shows as the block's output. Its lines must match what
the block printed, line by line, the same words and each number within one unit of the last digit it
shows; a line ``...`` stands for any lines, and ``…`` within a line for any text (what changes from run
to run: timings) (:func:`output_mismatches`). ``python -m tests.codeblocks PAGE...`` runs a page and writes its output
blocks.
"""

import itertools
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
PROGRAMS = {"python": "python", "py": "python", "bash": "bash", "sh": "bash", "shell": "bash", "console": "bash"}
FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>`{3,}|~{3,})(?P<info>[^`\n]*)$")
MARK = re.compile(r"^\s*<!--\s*not-run:\s*(?P<reason>.*?)\s*-->\s*$")
#: Commands an unmarked bash block may run.
RUNNABLE = re.compile(r"^(MUJOCO_GL=\w+ )?python -m mjflex ")
#: MuJoCo's default warning handler prints ``WARNING: <text>`` (and appends it to MUJOCO_LOG.TXT in the working folder).
MUJOCO_WARNING = re.compile(r"^WARNING: (?P<text>.*)$", re.M)
MUJOCO_LOG = "MUJOCO_LOG.TXT"
#: Python's ``warnings.formatwarning``: ``path:line: Category: message``.
PYTHON_WARNING = re.compile(r"^(?P<where>\S.*?):\d+: (?P<category>\w*Warning): (?P<text>.*)$", re.M)
#: A non-finite number in printed output: a diverged state or result printed as if it were one.
NON_FINITE = re.compile(r"(?<![\w.])[-+]?(nan|inf)(?![\w(])", re.I)


#: The language of a block that shows what the python block before it prints.
OUTPUT = "output"
#: An output block's line that stands for any lines; within a line, ``…`` stands for any text (a timing).
ANY_LINES = "..."
ANY_TEXT = "…"
#: What run_page prints after each python block, so that each block's output can be told apart.
_SEPARATOR = "\x1e-- end of block --"


@dataclass
class Block:
    path: str
    line: int  # 1-based line of the opening fence
    language: str  # "python", "bash", or the info string's first word for other blocks
    code: str
    skip: str | None  # the not-run reason, if marked
    end: int = 0  # 1-based line of the closing fence
    output: str | None = None  # a python block's output block (its text), if one follows it

    @property
    def program(self) -> bool:
        return self.language in ("python", "bash")

    def where(self) -> str:
        return f"{os.path.relpath(self.path, ROOT)}:{self.line}"


def blocks(path, text=None):
    """The fenced code blocks of a Markdown file, in order."""
    if text is None:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    lines = text.split("\n")
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info = m["fence"], m["info"].strip()
        word = info.split()[0].strip("{}") if info else ""
        mark = MARK.match(lines[i - 1]) if i > 0 else None
        j = i + 1
        while j < len(lines) and not lines[j].strip().startswith(fence):
            j += 1
        indent = m["indent"]
        body = "\n".join(line[len(indent) :] if line.startswith(indent) else line for line in lines[i + 1 : j])
        out.append(Block(path, i + 1, PROGRAMS.get(word.lower(), word), body + "\n", mark["reason"] if mark else None,
                         j + 1))  # fmt: skip
        i = j + 1
    for before, block in itertools.pairwise(out):
        between = lines[before.end : block.line - 1]
        if block.language == OUTPUT and before.language == "python" and not any(x.strip() for x in between):
            before.output = block.code
    return out


def commands(block):
    """The command lines of a bash block (continuation lines joined, comments dropped)."""
    joined = re.sub(r"\s*\\\n\s*", " ", block.code)
    lines = [line.split(" #")[0].strip() for line in joined.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def problems(block):
    """Why a program block can neither run nor stands marked, or prints without showing it; empty if fine."""
    if not block.program:
        return []
    if block.skip is not None:
        return [] if block.skip else [f"{block.where()}: 'not-run:' needs a reason"]
    if block.language == "bash":
        fix = "is not 'python -m mjflex ...': run it or mark the block"
        return [f"{block.where()}: {c!r} {fix}" for c in commands(block) if not RUNNABLE.match(c)]
    if "print(" in block.code and block.output is None:
        return [f"{block.where()}: prints, but no ```{OUTPUT} block after it shows what (python -m tests.codeblocks "
                f"{os.path.relpath(block.path, ROOT)} writes it)"]  # fmt: skip
    return []


def output_mismatches(where, expected, printed):
    """How ``printed`` (what a block printed) differs from its output block ``expected`` (empty: it matches)."""
    want = expected.rstrip("\n").split("\n") if expected.strip() else []
    got = printed.rstrip("\n").split("\n") if printed.strip() else []
    w = g = 0
    while w < len(want):
        if want[w].strip() == ANY_LINES:
            following = want[w + 1] if w + 1 < len(want) else None
            while g < len(got) and following is not None and not claim_matches(following, got[g]):
                g += 1
            if following is None:
                g = len(got)
            w += 1
            continue
        if g >= len(got) or not claim_matches(want[w], got[g]):
            shown = got[g] if g < len(got) else "(nothing more)"
            return [f"{where}: its output block says {want[w]!r}; the block printed {shown!r} there (write the "
                    "block again: python -m tests.codeblocks PAGE)"]  # fmt: skip
        w, g = w + 1, g + 1
    if g < len(got):
        return [f"{where}: the block printed {got[g]!r} and more, which its output block does not show"]
    return []


def output_problems(where, stdout, stderr, cwd=None):
    """What is wrong with the output of a block that exited with status 0 (empty: nothing).

    ``where`` names the block in the messages; ``cwd`` is the folder it ran in (its MuJoCo log is read, then
    removed, so that the next command starts clean).
    """
    found = [f"{where}: MuJoCo warned: {m['text']}" for m in MUJOCO_WARNING.finditer(stdout + stderr)]
    log = os.path.join(cwd, MUJOCO_LOG) if cwd else None
    if log and os.path.exists(log):
        with open(log, encoding="utf-8", errors="replace") as f:
            entries = [line.strip() for line in f if line.strip()]
        os.remove(log)
        if not found:  # the log holds what was printed; without a printed line, say what the log holds
            found += [f"{where}: MuJoCo's log {MUJOCO_LOG}: {entry}" for entry in entries]
    found += [f"{where}: {m['category']} printed: {m['text']}" for m in PYTHON_WARNING.finditer(stderr)]
    found += [f"{where}: printed a non-finite number ({m[0]!r}) in: {line.strip()!r}"
              for line in stdout.splitlines() if not MUJOCO_WARNING.match(line)
              for m in NON_FINITE.finditer(line)]  # fmt: skip
    return found


#: A number of a printed line or of a claim about it.
_PRINTED_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def printed_claims(block):
    """What a python block's comments say it prints: each comment line right below a line that starts with
    ``print(``, at the same indentation (its text after ``# ``)."""
    lines = block.code.split("\n")
    indent = [len(line) - len(line.lstrip()) for line in lines]
    return [line.strip()[2:] for k, line in enumerate(lines[1:], 1)
            if line.strip().startswith("# ") and lines[k - 1].strip().startswith("print(")
            and indent[k] == indent[k - 1]]  # fmt: skip


def _one_unit(number):
    """One unit of the last digit ``number`` shows: ``0.1272`` -> 1e-4, ``3.5e-05`` -> 1e-6, ``16`` -> 1."""
    mantissa, _, exponent = number.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 10.0 ** (int(exponent or 0) - decimals)


def claim_matches(claim, line):
    """``line`` says what ``claim`` says: the same text, and each number within one unit of the claim's last digit
    (``…`` in the claim: any text there)."""
    said = _PRINTED_NUMBER.findall(claim)
    pattern = f"({_PRINTED_NUMBER.pattern})".join(
        ".*?".join(re.escape(text) for text in part.split(ANY_TEXT)) for part in _PRINTED_NUMBER.split(claim)
    )
    m = re.fullmatch(pattern, line.strip())
    if not m:
        return False
    return all(abs(float(got) - float(x)) <= 1.000001 * _one_unit(x) for x, got in zip(said, m.groups(), strict=True))


def claim_problems(where, claims, stdout):
    """The claims (:func:`printed_claims`) that no line of ``stdout`` matches."""
    lines = stdout.splitlines()
    return [f"{where}: the comment says it prints {claim!r}; no printed line matches" for claim in claims
            if not any(claim_matches(claim, line) for line in lines)]  # fmt: skip


def workspace(tmp_path):
    """A folder with a copy of the repository's models/, for blocks written from the repository root."""
    shutil.copytree(os.path.join(ROOT, "models"), os.path.join(tmp_path, "models"))
    return str(tmp_path)


def environment():
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")  # `python` is this venv's
    if sys.platform.startswith("linux") and not env.get("DISPLAY"):
        env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("MPLBACKEND", "agg")
    return env


def _run_python_blocks(python, cwd, env, timeout):
    """Run python blocks in order as one script (``page.py`` in ``cwd``), a separator line printed after each."""
    # (a worker process that imports the script as __mp_main__, as Dask's and a process pool's do, prints none)
    end = f"if __name__ == '__main__':\n    print({_SEPARATOR!r}, flush=True)\n"
    script = "".join(f"# {b.where()}\n{b.code}\n{end}" for b in python)
    with open(os.path.join(cwd, "page.py"), "w") as f:
        f.write(script)
    return subprocess.run([sys.executable, "page.py"], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)  # fmt: skip


def write_outputs(page, tmp):
    """Run the python blocks of ``page`` (in the workspace folder ``tmp``) and write after each one that prints an
    output block of what it printed (replacing the one it had). Returns the number of blocks written."""
    text = open(page, encoding="utf-8").read()
    lines = text.split("\n")
    python = [b for b in blocks(page, text) if b.language == "python" and b.skip is None]
    done = _run_python_blocks(python, workspace(tmp), environment(), 600)
    if done.returncode:
        raise SystemExit(f"{page}: the python blocks failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    printed = done.stdout.split(_SEPARATOR + "\n")
    all_blocks = blocks(page, text)
    written = 0
    for block, out in reversed(list(zip(python, printed, strict=False))):
        if not out.strip() and block.output is None:
            continue
        fence = "```"
        new = ["", f"{fence}{OUTPUT}", *out.rstrip("\n").split("\n"), fence]
        old = next((b for b in all_blocks if b.language == OUTPUT and b.line > block.end), None)
        if block.output is not None and old is not None:
            lines[block.end : old.end] = new
        else:
            lines[block.end : block.end] = new
        written += 1
    with open(page, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    return written


def run_page(page_blocks, cwd, timeout=600):
    """Run the unmarked program blocks of one page; returns a list of failures (empty: all ran)."""
    failures, env = [], environment()
    python = [b for b in page_blocks if b.language == "python" and b.skip is None]
    if python:
        done = _run_python_blocks(python, cwd, env, timeout)
        if done.returncode:
            failures.append(f"{python[0].where()} (python blocks): exit {done.returncode}\n{done.stderr[-3000:]}")
        else:
            printed = done.stdout.split(_SEPARATOR + "\n")
            stdout = "".join(printed)
            failures += output_problems(f"{python[0].where()} (python blocks)", stdout, done.stderr, cwd)
            claims = [claim for b in python for claim in printed_claims(b)]
            failures += claim_problems(f"{python[0].where()} (python blocks)", claims, stdout)
            for block, out in zip(python, printed, strict=False):
                if block.output is not None:
                    failures += output_mismatches(block.where(), block.output, out)
    for block in (b for b in page_blocks if b.language == "bash" and b.skip is None):
        for command in commands(block):
            done = subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True,
                                  timeout=timeout)  # fmt: skip
            if done.returncode:
                failures.append(f"{block.where()}: {command!r}: exit {done.returncode}\n{done.stderr[-3000:]}")
            else:
                failures += output_problems(f"{block.where()}: {command!r}", done.stdout, done.stderr, cwd)
    return failures


if __name__ == "__main__":  # python -m tests.codeblocks PAGE...: write the pages' output blocks
    import tempfile

    for name in sys.argv[1:]:
        with tempfile.TemporaryDirectory() as folder:
            print(f"{name}: {write_outputs(os.path.abspath(name), folder)} output block(s) written")
