"""A module imported on first use (:class:`LazyModule`): for names a light import should not
pay for (JAX's ≈ 2 s, when only the damping laws' descriptions are read)."""

from __future__ import annotations

import importlib


class LazyModule:
    """Stands for the module ``name``: ``obj.attr`` imports it on first use and caches each
    attribute it hands out, so later look-ups cost one dict access."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr: str):
        if attr.startswith("__"):  # copy, pickle, inspect probe dunders: not the module's
            raise AttributeError(attr)
        value = getattr(importlib.import_module(self._name), attr)
        self.__dict__[attr] = value
        return value

    def __repr__(self) -> str:
        return f"<lazy module {self._name}>"
