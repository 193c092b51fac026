"""The figures of a result folder, for byte-for-byte comparisons."""

from __future__ import annotations


def pngs(folder) -> dict[str, bytes]:
    """Every ``*.png`` of ``folder``: name → bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.glob("*.png"))}
