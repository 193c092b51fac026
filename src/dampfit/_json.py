"""Plain-data conversion shared by every summary: NumPy → JSON-safe Python."""

from __future__ import annotations

import math

from typing import Any

import numpy as np


def jsonable(obj: Any) -> Any:
    """Recursively turn NumPy scalars/arrays (and tuples) into JSON-safe Python; non-finite
    floats become None, dict keys strings."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    return obj


def finite(x) -> float | None:
    """``x`` as a float, or None if missing or not finite (JSON-safe)."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None
