"""The import graph of the package: a pure library under a thin command line.

(a) No module of ``src/dampfit`` outside ``dampfit/cli`` (and ``dampfit/__main__.py``, which
is ``python -m dampfit``) imports ``dampfit.cli`` — in any
form: ``import``, ``from … import``, relative, inside a function, or a module name given to
``importlib.import_module``/``__import__`` as a string.
(b) The numeric core (``dampfit.model``, ``dampfit.inference``, ``dampfit.signal``,
``dampfit.physics``) imports neither matplotlib nor ``dampfit.output``/``fem``/``study``/``cli``,
directly or through other dampfit modules.

The graph is read with :mod:`ast` from the source files (nothing is imported), and the
checker is itself tested on synthetic sources, so the test can fail.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import dampfit

SRC = Path(dampfit.__file__).resolve().parent
CORE = ("dampfit.model", "dampfit.inference", "dampfit.signal", "dampfit.physics")
FORBIDDEN_IN_CORE = ("matplotlib", "dampfit.output", "dampfit.fem", "dampfit.study", "dampfit.cli")
#: A string that is exactly a module name of the package (as given to importlib).
_MODULE_STRING = re.compile(r"^dampfit(\.[A-Za-z_]\w*)*$")


def module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every module name ``source`` (the text of ``module``) imports, anywhere in the file.

    ``from A import b`` counts as both ``A`` and ``A.b`` (b may be a submodule); relative
    imports are resolved against ``module``; string constants that are exactly a dampfit
    module name (``importlib.import_module("dampfit.cli")``) count too, as do the string
    arguments of ``import_module``/``__import__`` calls (``import_module(".cli", "dampfit")``).
    """
    tree = ast.parse(source)
    package = module if is_package else module.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            out.add(prefix)
            out.update(f"{prefix}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in ("import_module", "__import__") and node.args:
                arg = node.args[0]
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    target = arg.value
                    if target.startswith("."):  # import_module(".cli", "dampfit")
                        anchor = node.args[1] if len(node.args) > 1 else None
                        if isinstance(anchor, ast.Constant) and isinstance(anchor.value, str):
                            target = anchor.value + target
                    out.add(target)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            if _MODULE_STRING.match(node.value):
                out.add(node.value)
    return out


def _modules() -> dict[str, tuple[Path, set[str]]]:
    mods = {}
    for path in sorted(SRC.rglob("*.py")):
        name = module_name(path)
        mods[name] = (path, imports_of(path.read_text(encoding="utf-8"), name,
                                       path.name == "__init__.py"))
    return mods


def _hits(imported: set[str], prefixes: tuple[str, ...]) -> set[str]:
    return {m for m in imported for p in prefixes if m == p or m.startswith(p + ".")}


def _reachable(start: str, mods: dict[str, tuple[Path, set[str]]]) -> dict[str, str]:
    """Every dampfit module ``start`` imports directly or through other dampfit modules
    (the root package ``dampfit`` itself excluded: it re-exports everything), with the
    module that imports it."""
    seen: dict[str, str] = {}
    todo = [start]
    while todo:
        cur = todo.pop()
        for imp in mods[cur][1]:
            if imp in mods and imp != "dampfit" and imp not in seen and imp != start:
                seen[imp] = cur
                todo.append(imp)
    return seen


def cli_violations(mods) -> list[str]:
    return sorted(f"{name} imports {', '.join(sorted(_hits(imps, ('dampfit.cli',))))}"
                  for name, (_, imps) in mods.items()
                  if not (name in ("dampfit.cli", "dampfit.__main__") or name.startswith("dampfit.cli."))
                  and _hits(imps, ("dampfit.cli",)))


def core_violations(mods) -> list[str]:
    bad = []
    for name in mods:
        if not any(name == c or name.startswith(c + ".") for c in CORE):
            continue
        direct = _hits(mods[name][1], FORBIDDEN_IN_CORE)
        if direct:
            bad.append(f"{name} imports {', '.join(sorted(direct))}")
        for dep, via in _reachable(name, mods).items():
            hit = _hits(mods[dep][1], ("matplotlib",)) | _hits({dep}, FORBIDDEN_IN_CORE)
            if hit:
                bad.append(f"{name} reaches {', '.join(sorted(hit))} through {dep} (imported by {via})")
    return sorted(set(bad))


# ----------------------------------------------------------------------------- the package
def test_the_package_is_found():
    mods = _modules()
    assert "dampfit.cli" in mods and "dampfit.pipeline" in mods and "dampfit.model.viscous" in mods
    assert any(name.startswith("dampfit.inference.") for name in mods)


def test_no_library_module_imports_the_cli():
    assert cli_violations(_modules()) == []


def test_numeric_core_imports_no_plotting_output_fem_study_or_cli():
    assert core_violations(_modules()) == []


# ----------------------------------------------------------------------------- the checker
@pytest.mark.parametrize("source", [
    "import dampfit.cli\n",
    "from dampfit.cli import float_arg\n",
    "from dampfit import cli\n",
    "from ..cli import main\n",
    "from .. import cli\n",
    "def f():\n    from dampfit.cli.options import float_arg\n    return float_arg\n",
    "import importlib\n\ndef f():\n    return importlib.import_module('dampfit.cli')\n",
    "import importlib\n\ndef f():\n    return importlib.import_module('.cli', 'dampfit')\n",
    "def f():\n    return __import__('dampfit.cli.export')\n",
    "MODULE = 'dampfit.cli'\n",
])
def test_checker_finds_every_form_of_importing_the_cli(source):
    mods = _modules()
    mods["dampfit.fem.fake"] = (Path("fake.py"), imports_of(source, "dampfit.fem.fake"))
    assert [v for v in cli_violations(mods) if v.startswith("dampfit.fem.fake ")] == ["dampfit.fem.fake imports " + ", ".join(
        sorted(_hits(mods["dampfit.fem.fake"][1], ("dampfit.cli",))))]


def test_checker_allows_the_cli_itself_and_mentions_in_prose():
    mods = _modules()
    mods["dampfit.cli.fake"] = (Path("fake.py"), imports_of("from dampfit.cli import options\n",
                                                           "dampfit.cli.fake"))
    mods["dampfit.fem.fake"] = (Path("fake.py"), imports_of(
        '"""See :mod:`dampfit.cli.export` for the command."""\nimport dampfit.client_side\n',
        "dampfit.fem.fake"))
    assert [v for v in cli_violations(mods) if "fake" in v] == []


@pytest.mark.parametrize("source,found", [
    ("import matplotlib.pyplot as plt\n", "matplotlib"),
    ("def f():\n    from matplotlib.figure import Figure\n", "matplotlib"),
    ("from dampfit.output import figures\n", "dampfit.output"),
    ("from ...fem import sdof\n", "dampfit.fem"),
    ("from dampfit import study\n", "dampfit.study"),
])
def test_checker_finds_forbidden_imports_of_the_core(source, found):
    mods = _modules()
    mods["dampfit.inference.fake.deep"] = (Path("fake.py"),
                                           imports_of(source, "dampfit.inference.fake.deep"))
    bad = [b for b in core_violations(mods) if b.startswith("dampfit.inference.fake.deep imports ")]
    assert len(bad) == 1 and found in bad[0]


def test_checker_finds_a_forbidden_import_through_another_module():
    mods = _modules()
    mods["dampfit.helper_fake"] = (Path("fake.py"), imports_of("import matplotlib\n",
                                                              "dampfit.helper_fake"))
    mods["dampfit.model.fake"] = (Path("fake.py"), imports_of("from dampfit import helper_fake\n",
                                                             "dampfit.model.fake"))
    bad = core_violations(mods)
    assert any("dampfit.model.fake reaches matplotlib through dampfit.helper_fake" in b for b in bad)
