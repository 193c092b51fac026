"""The import graph of the package: a pure library under a thin command line.

(a) No module of ``src/dampfit`` outside ``dampfit/cli`` (and ``dampfit/__main__.py``, which
is ``python -m dampfit``) imports ``dampfit.cli`` — in any
form: ``import``, ``from … import``, relative, inside a function, or a module name given to
``importlib.import_module``/``__import__`` as a string.
(b) The numeric core (``dampfit.model``, ``dampfit.inference``, ``dampfit.signal``,
``dampfit.physics``) imports neither matplotlib nor ``dampfit.output``/``fem``/``study``/``cli``,
directly or through other dampfit modules.
(c) The package stands in floors (:data:`LAYERS`, bottom up; ARCHITECTURE.md draws them): a
module imports only from its own floor or lower ones — no import climbs back up — and no
modules import each other in a circle (imports under ``if TYPE_CHECKING:`` aside).
(d) No module uses another module's private name (``from m import _x`` or ``m._x``).

The graph is read with :mod:`ast` from the source files (nothing is imported), and the
checker is itself tested on synthetic sources, so the test can fail.
"""

from __future__ import annotations

import ast
import functools
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


# ----------------------------------------------------------------------------- floors
#: The floors of the package, bottom up: (module or package, floor). A module belongs to the
#: longest prefix listed. ARCHITECTURE.md shows the same order.
LAYERS = (
    ("dampfit.errors", 0), ("dampfit._meta", 0), ("dampfit._json", 0), ("dampfit._progress", 0),
    ("dampfit._child", 0), ("dampfit._arviz", 0), ("dampfit._lazy", 0),
    ("dampfit._options", 1), ("dampfit.physics", 1), ("dampfit.physics_modal", 1), ("dampfit.model", 1),
    ("dampfit.io", 2), ("dampfit.files", 2), ("dampfit.cluster", 2),
    ("dampfit.signal", 3), ("dampfit.simulate", 3),
    ("dampfit.inference", 4),
    ("dampfit.estimators", 5), ("dampfit.damping", 5),
    ("dampfit.stages", 6),
    ("dampfit.result", 7),
    ("dampfit.output", 8),
    ("dampfit.analysis", 9), ("dampfit.pipeline", 9), ("dampfit.campaign", 9),
    ("dampfit.warmup", 9),
    ("dampfit.fem", 10), ("dampfit.record", 10),
    ("dampfit.study", 11), ("dampfit.batch", 11),
    ("dampfit.api", 12),
    ("dampfit", 13), ("dampfit.cli", 13), ("dampfit.__main__", 13),
)


def floor(module: str) -> int | None:
    """The floor of ``module`` (:data:`LAYERS`; the root ``dampfit`` is the face only), None
    if it is on none."""
    best = None
    for prefix, level in LAYERS:
        if prefix == "dampfit" and module != "dampfit":
            continue
        if (module == prefix or module.startswith(prefix + ".")) and (
                best is None or len(prefix) > len(best[0])):
            best = (prefix, level)
    return None if best is None else best[1]


def import_edges(source: str, module: str, known: set[str],
                 is_package: bool = False) -> list[tuple[str, int, list[str]]]:
    """``(imported module, line, names taken)`` of every dampfit import statement in
    ``source`` outside ``if TYPE_CHECKING:`` blocks. ``from pkg import sub`` is an import of
    the submodule ``pkg.sub`` when it is one of ``known`` (not of ``pkg``'s face)."""
    tree = ast.parse(source)
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    package = module if is_package else module.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno, []) for a in node.names if a.name.split(".")[0] == "dampfit"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            if prefix.split(".")[0] != "dampfit":
                continue
            for alias in node.names:
                full = f"{prefix}.{alias.name}"
                out.append((full, node.lineno, []) if full in known
                           else (prefix, node.lineno, [alias.name]))
    return out


def _graph(sources: dict[str, tuple[str, bool]]) -> dict[str, list[tuple[str, int, list[str]]]]:
    known = set(sources)
    graph = {}
    for name, (source, is_package) in sources.items():
        edges = []
        for target, line, names in import_edges(source, name, known, is_package):
            while target not in known and "." in target:
                target = target.rpartition(".")[0]
            edges.append((target, line, names))
        graph[name] = edges
    return graph


def _sources() -> dict[str, tuple[str, bool]]:
    """``{module: (source, is a package)}`` of the installed package (a fresh dict)."""
    return dict(_read_sources())


@functools.lru_cache(maxsize=1)
def _read_sources() -> tuple[tuple[str, tuple[str, bool]], ...]:
    return tuple((module_name(p), (p.read_text(encoding="utf-8"), p.name == "__init__.py"))
                 for p in sorted(SRC.rglob("*.py")))


def floor_violations(sources) -> list[str]:
    """Modules on no floor, and imports that climb to a higher floor."""
    bad = []
    for name, edges in _graph(sources).items():
        own = floor(name)
        if own is None:
            bad.append(f"{name} is on no floor of LAYERS")
            continue
        for target, line, _ in edges:
            up = floor(target)
            if up is not None and up > own:
                bad.append(f"{name}:{line} imports {target} (floor {own} -> {up})")
    return sorted(bad)


def circles(sources) -> list[list[str]]:
    """The import circles (strongly connected components of more than one module)."""
    graph = {name: {t for t, _, _ in edges if t != name} for name, edges in _graph(sources).items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def private_uses(sources) -> list[str]:
    """Uses of another module's private name: ``from m import _x`` and ``m._x`` where ``m``
    is a dampfit module imported under a name."""
    known = set(sources)
    bad = []
    for name, (source, is_package) in sources.items():
        bound = {}
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ImportFrom) or isinstance(node, ast.Import):
                for target, line, names in import_edges(ast.unparse(node), name, known,
                                                        is_package):
                    for n in names:
                        if n.startswith("_") and not n.startswith("__") and target != name:
                            bad.append(f"{name}:{node.lineno} imports {target}.{n}")
                for alias in node.names:
                    full = (alias.name if isinstance(node, ast.Import)
                            else next((t for t, _, ns in import_edges(ast.unparse(node), name,
                                                                      known, is_package)
                                       if t.endswith("." + alias.name) and not ns), None))
                    if full in known and (alias.asname or isinstance(node, ast.ImportFrom)):
                        bound[alias.asname or alias.name] = full
        for node in ast.walk(ast.parse(source)):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in bound and bound[node.value.id] != name
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                bad.append(f"{name}:{node.lineno} uses {bound[node.value.id]}.{node.attr}")
    return sorted(set(bad))


def test_no_import_climbs_to_a_higher_floor():
    assert floor_violations(_sources()) == []


def test_no_import_circles():
    assert circles(_sources()) == []


def test_no_module_uses_another_modules_private_names():
    assert private_uses(_sources()) == []


def test_floor_checker_finds_a_climbing_import_and_an_unlisted_module():
    src = _sources()
    src["dampfit.model.fake_up"] = ("from dampfit.output import text\n", False)
    src["dampfit.nowhere"] = ("x = 1\n", False)
    bad = floor_violations(src)
    assert any(b.startswith("dampfit.model.fake_up:1 imports dampfit.output.text") for b in bad)
    assert "dampfit.nowhere is on no floor of LAYERS" in bad


def test_floor_checker_skips_type_checking_imports():
    src = _sources()
    src["dampfit.model.fake"] = ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                 "    from dampfit.analysis import Analysis\n", False)
    assert not [b for b in floor_violations(src) if "fake" in b]


def test_circle_checker_finds_a_circle_through_functions():
    src = _sources()
    src["dampfit.io.fake_a"] = ("def f():\n    from dampfit.io import fake_b\n", False)
    src["dampfit.io.fake_b"] = ("from dampfit.io.fake_a import f\n", False)
    assert ["dampfit.io.fake_a", "dampfit.io.fake_b"] in circles(src)


@pytest.mark.parametrize("source", [
    "from dampfit.output.text import _fixed\n",
    "from dampfit.output import text\n\ndef f():\n    return text._fixed(1, 2)\n",
    "import dampfit.output.text as t\nt._fixed\n",
])
def test_private_checker_finds_every_form(source):
    src = _sources()
    src["dampfit.fem.fake"] = (source, False)
    assert [b for b in private_uses(src) if b.startswith("dampfit.fem.fake:")]


def test_private_checker_allows_a_modules_own_names_and_dunders():
    src = _sources()
    src["dampfit.fem.fake"] = ("import dampfit\n_x = 1\nprint(_x, dampfit.__version__)\n", False)
    assert not [b for b in private_uses(src) if b.startswith("dampfit.fem.fake:")]
