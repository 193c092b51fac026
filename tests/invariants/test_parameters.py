"""Issue 37, "Done when": no function in src/dampfit takes more than 8 parameters, except the
face's keyword-only options.

The face is what ``dampfit`` hands out (its lazy table: ``analyze``, ``analyze_many``,
``analyze_campaign``, ``read``, ``load`` … and the modules ``dampfit.crlb`` and
``dampfit.simulate``, whose public functions are the simulator's): a face function may take
any number of keyword-only options but at most :data:`MAX` positional parameters. Every other
function takes at most :data:`MAX` parameters in all (``self``/``cls`` not counted; ``*args``
and ``**kwargs`` count one each). Values that always travel together go as one object
(:class:`~dampfit._options.AnalysisOptions`, :class:`~dampfit._options.SamplerSettings`,
:class:`~dampfit.physics.Mass`, a result dataclass or a small named tuple), never as a bag.
"""

from __future__ import annotations

import ast
import importlib
import inspect
from pathlib import Path

def _package_root() -> Path:
    """The folder of the dampfit that is imported: src/dampfit of a checkout, or site-packages'
    copy after ``pip install .`` (CI, a user), whose sources are the same files."""
    import dampfit

    return Path(dampfit.__file__).resolve().parent


SRC = _package_root()
MAX = 8
#: Modules the face hands out whole: their public top-level functions are face functions.
FACE_MODULES = ("inference/crlb.py", "simulate/")


def _face() -> set[tuple[str, str]]:
    """(path relative to src/dampfit, function name) of every face function."""
    import dampfit

    out = set()
    for module, attr in dampfit._LAZY.values():
        if attr is None:
            continue
        obj = inspect.unwrap(getattr(importlib.import_module(module), attr))
        if inspect.isfunction(obj):
            out.add((Path(inspect.getsourcefile(obj)).resolve().relative_to(SRC).as_posix(),
                     obj.__name__))
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if any(rel == m or (m.endswith("/") and rel.startswith(m)) for m in FACE_MODULES):
            for node in ast.parse(path.read_text(encoding="utf-8")).body:
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                        and not node.name.startswith("_"):
                    out.add((rel, node.name))
    return out


def _counts(node: ast.FunctionDef | ast.AsyncFunctionDef) -> tuple[int, int]:
    """(positional parameters, all parameters) of ``node``, ``self``/``cls`` not counted."""
    a = node.args
    positional = len(a.posonlyargs) + len(a.args)
    first = (a.posonlyargs + a.args)[:1]
    if first and first[0].arg in ("self", "cls"):
        positional -= 1
    return positional, positional + len(a.kwonlyargs) + bool(a.vararg) + bool(a.kwarg)


def offenders() -> list[str]:
    face = _face()
    out = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            positional, total = _counts(node)
            top_level_face = (rel, node.name) in face
            if (positional if top_level_face else total) > MAX:
                out.append(f"{rel}:{node.lineno} {node.name}: {positional} positional, "
                           f"{total} in all")
    return out


def test_no_function_takes_more_than_eight_parameters():
    assert offenders() == []


def test_the_rule_sees_a_long_signature(tmp_path):
    """The counting itself: nine parameters break the rule, keyword-only or not; self does
    not count; a face function may have keyword-only options beyond eight."""
    tree = ast.parse("def f(a, b, c, d, e, f, g, h, *, i): pass\n"
                     "def g(self, a, b, c, d, e, f, g, h): pass\n"
                     "def h(a, b, *args, **kw): pass\n")
    f, g, h = tree.body
    assert _counts(f) == (8, 9) and _counts(g) == (8, 8) and _counts(h) == (2, 4)
    assert ("api.py", "analyze") in _face() and ("simulate/structure.py", "two_modes") in _face()
