"""README.md stays short and true: what it names exists, and the Quick start stays two commands.

* every module it names — ``dampfit.x.y`` (a module, or a name defined in one) or a path
  ``src/dampfit/…`` — exists in this checkout, and so does every local file it links to;
* every ``dampfit COMMAND`` in its code (inline spans and fenced blocks) is a command of the
  CLI (:data:`dampfit.cli.COMMANDS`);
* it is at most :data:`MAX_BYTES` long and has a table of contents near the top whose links
  all lead to headings of the README;
* the Quick start's ```bash block holds exactly two commands, the second the test command
  (``.ci/run`` runs the second line of that block).

Each checker is also run on synthetic text that must fail it, so the test can fail.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

import dampfit

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
SRC = Path(dampfit.__file__).resolve().parent
#: Largest README [bytes] (issue 20: the detail lives in paper/ and in the docstrings; the
#: glossary and the details of batch, record and FEM are in paper/usage.md).
MAX_BYTES = 15_000
#: The table of contents must start within this many lines of the top.
TOC_WITHIN_LINES = 40

#: ``dampfit.x.y`` not inside a longer dotted name or a path (``decay.dampfit``, ``x/dampfit``).
_MODULE = re.compile(r"(?<![\w./-])dampfit(?:\.[A-Za-z_]\w*)+")
#: A path into the package source.
_SRC_PATH = re.compile(r"(?<![\w/.-])src/dampfit(?:/[\w.-]+)*/?")
#: ``dampfit COMMAND`` at the start of a command (not ``python -m dampfit``'s arguments alone).
_COMMAND = re.compile(r"(?:^|[\s`(|&;$])dampfit ([a-z][\w-]*)")
_FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.M | re.S)
_SPAN = re.compile(r"`([^`\n]+)`")
_LINK = re.compile(r"\]\(([^)\s]+)\)")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*$", re.M)


def text() -> str:
    return README.read_text(encoding="utf-8")


def code_of(md: str) -> list[str]:
    """The code of ``md``: fenced blocks and inline spans (outside the blocks)."""
    blocks = _FENCE.findall(md)
    rest = _FENCE.sub("", md)
    return blocks + _SPAN.findall(rest)


# ----------------------------------------------------------------------------- checkers
def _module_file(parts: list[str]) -> Path | None:
    base = SRC.parent.joinpath(*parts)
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return candidate
    return None


def missing_modules(md: str) -> list[str]:
    """The ``dampfit.x.y`` names of ``md`` that are neither a module of the package nor a
    name defined in one (the longest module prefix is imported and the rest looked up)."""
    bad = []
    for name in sorted(set(_MODULE.findall(md))):
        parts = name.split(".")
        k = len(parts)
        while k > 1 and _module_file(parts[:k]) is None:
            k -= 1
        if _module_file(parts[:k]) is None:
            bad.append(name)
            continue
        if k == len(parts):
            continue
        obj = importlib.import_module(".".join(parts[:k]))
        for attr in parts[k:]:
            if not hasattr(obj, attr):
                bad.append(name)
                break
            obj = getattr(obj, attr)
    return bad


def missing_paths(md: str) -> list[str]:
    """``src/dampfit/…`` paths and local link targets of ``md`` that do not exist."""
    paths = set(_SRC_PATH.findall(md))
    for target in _LINK.findall(md):
        if re.match(r"^[a-z]+:", target) or target.startswith("#"):
            continue  # a URL or an anchor of the README itself
        paths.add(target.split("#")[0])
    return sorted(p for p in paths if not (ROOT / p.rstrip("/")).exists())


def cli_commands() -> set[str]:
    from dampfit.cli import COMMANDS

    return {name for name, *_ in COMMANDS}


def unknown_commands(md: str, known: set[str]) -> list[str]:
    """``dampfit COMMAND`` in the code of ``md`` whose COMMAND is not one of ``known``."""
    found = {m for code in code_of(md) for m in _COMMAND.findall(code)}
    return sorted(found - known)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, markup and punctuation dropped, spaces → -."""
    h = re.sub(r"<!--.*?-->", "", heading).strip().lower()
    h = re.sub(r"[^\w\- ]", "", h)
    return h.replace(" ", "-")


def toc_problems(md: str) -> list[str]:
    """Why ``md`` has no usable table of contents near the top (empty list: it has one)."""
    lines = md.splitlines()
    start = next((i for i, line in enumerate(lines[:TOC_WITHIN_LINES])
                  if re.match(r"^#{2,3}\s+(table of )?contents\b", line, re.I)), None)
    if start is None:
        return [f"no '## Contents' heading in the first {TOC_WITHIN_LINES} lines"]
    block = []
    for line in lines[start + 1:]:
        if line.startswith("#"):
            break
        block.append(line)
    anchors = re.findall(r"\]\(#([^)]+)\)", "\n".join(block))
    if len(anchors) < 5:
        return [f"the table of contents links {len(anchors)} sections, expected at least 5"]
    headings = {slug(h) for _, h in _HEADING.findall(_FENCE.sub("", md))}
    return [f"#{a} leads to no heading" for a in anchors if a not in headings]


def quick_start_commands(md: str) -> list[str]:
    """The commands of the first ```bash block after the Quick start heading, as ``.ci/run``
    reads them (comments and blank lines dropped)."""
    m = re.search(r"^#+ .*quick ?start.*$", md, re.I | re.M)
    if m is None:
        return []
    block = re.search(r"^```bash\n(.*?)^```", md[m.end():], re.M | re.S)
    if block is None:
        return []
    lines = [re.sub(r"\s#.*$", "", line).strip() for line in block.group(1).splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


# ----------------------------------------------------------------------------- the README
def test_readme_is_short():
    size = len(README.read_bytes())
    assert size <= MAX_BYTES, f"README.md is {size} bytes, more than {MAX_BYTES}"


def test_readme_has_a_table_of_contents():
    assert toc_problems(text()) == []


def test_quick_start_has_exactly_two_commands_the_second_runs_the_tests():
    cmds = quick_start_commands(text())
    assert len(cmds) == 2, cmds
    assert "dampfit demo" in cmds[0]
    assert "pytest" in cmds[1]


def test_readme_names_only_modules_that_exist():
    md = text()
    assert _MODULE.findall(md), "the checker found no module names at all"
    assert missing_modules(md) == []


def test_readme_names_only_paths_that_exist():
    assert missing_paths(text()) == []


def test_readme_names_only_commands_that_exist():
    md = text()
    known = cli_commands()
    assert {m for c in code_of(md) for m in _COMMAND.findall(c)} & known, "no command found"
    assert unknown_commands(md, known) == []


# ----------------------------------------------------------------------------- the checkers
@pytest.mark.parametrize("md,bad", [
    ("see `dampfit.damping.compare` for the rule", "dampfit.damping.compare"),
    ("the reader `dampfit.io.readers.no_such_reader`", "dampfit.io.readers.no_such_reader"),
    ("`dampfit.nowhere`", "dampfit.nowhere"),
])
def test_module_checker_finds_a_missing_module(md, bad):
    assert missing_modules(md) == [bad]


def test_module_checker_accepts_modules_names_and_other_dotted_words():
    md = ("`dampfit.io.readers`, `dampfit.damping.checks`, `dampfit.read`, "
          "`dampfit.simulate.preset`, \"decay.dampfit\", pip install \"dampfit[fem]\"")
    assert missing_modules(md) == []


def test_path_checker_finds_a_missing_path_and_link():
    md = "in `src/dampfit/damping/compare.py` and [here](paper/nowhere.md#x), [ok](README.md)"
    assert missing_paths(md) == ["paper/nowhere.md", "src/dampfit/damping/compare.py"]


def test_command_checker_finds_an_unknown_command_in_code_only():
    md = ("dampfit returns c in prose.\n\n```bash\ndampfit analyze x.csv\ndampfit fit x.csv\n```\n"
          "and `dampfit calibrate DIR`, `python -m dampfit --help`")
    assert unknown_commands(md, cli_commands()) == ["calibrate", "fit"]


def test_toc_checker_wants_contents_near_the_top_and_live_anchors():
    no_toc = "# x\n\n## Quick start\n"
    assert toc_problems(no_toc)
    dead = ("# x\n## Contents\n- [a](#a)\n- [b](#b)\n- [c](#c)\n- [d](#d)\n- [gone](#gone)\n"
            "## A\n## B\n## C\n## D\n")
    assert toc_problems(dead) == ["#gone leads to no heading"]


def test_quick_start_checker_counts_commands():
    three = "## Quick start\n\n```bash\npip install .\ndampfit demo  # run\npytest\n```\n"
    assert quick_start_commands(three) == ["pip install .", "dampfit demo", "pytest"]
