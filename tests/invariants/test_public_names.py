"""Issue 37: a private inside and a small face.

Only the documented face declares public names (``__all__``): ``dampfit`` itself, ``api``, the
two modules the face hands out whole (``dampfit.simulate``, ``dampfit.crlb``) and ``errors``.
Every other module is implementation: its names may be imported inside the package, but no
``__all__`` promises them to users. The count below is the size of the promise; a change to it
is a change to the documented surface and belongs in the README's "From Python".
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "dampfit"
FACE = {"__init__.py", "api.py", "simulate/__init__.py", "inference/crlb.py", "errors.py"}
#: the face's public names, counted (dampfit.__all__ is built from its lazy table at run time)
MAX_PUBLIC = 55


def _all_names(path: Path) -> list[str] | None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else (
            [node.target] if isinstance(node, (ast.AnnAssign, ast.AugAssign)) else [])
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
            try:
                return list(ast.literal_eval(node.value))
            except ValueError:  # built from other names: counted by importing it below
                return []
    return None


def _modules():
    return sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def test_only_the_face_declares_public_names():
    declaring = {p.relative_to(SRC).as_posix() for p in _modules() if _all_names(p) is not None}
    assert declaring <= FACE, f"implementation modules with __all__: {sorted(declaring - FACE)}"


def test_the_face_is_small_and_every_name_in_it_exists():
    import importlib

    import dampfit

    total = len(dampfit.__all__)
    for rel in sorted(FACE - {"__init__.py"}):
        name = "dampfit." + rel.removesuffix(".py").removesuffix("/__init__").replace("/", ".")
        module = importlib.import_module(name)
        names = list(getattr(module, "__all__", []))
        missing = [n for n in names if not hasattr(module, n)]
        assert not missing, f"{name}.__all__ names what it does not define: {missing}"
        total += len(names)
    for name in dampfit.__all__:
        assert getattr(dampfit, name) is not None
    assert total <= MAX_PUBLIC, f"the public surface grew to {total} names (at most {MAX_PUBLIC})"


@pytest.mark.parametrize("name", ["analyze", "read", "load", "analyze_many", "analyze_campaign",
                                  "Analysis", "CampaignAnalysis", "Recording", "simulate", "crlb"])
def test_the_documented_names_are_in_the_face(name):
    import dampfit

    assert name in dampfit.__all__
