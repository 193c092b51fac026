"""Optional dependencies and the real recordings (``DAMPFIT_REQUIRE_ALL``).

A test that needs something the machine may lack (OpenSeesPy and its BLAS/LAPACK, Chromium,
the real recordings in ../shared) calls :func:`require` (or uses a fixture built on it such as
``requires_opensees`` in ``tests/conftest.py``): it skips with the one-line reason, or — when the
environment variable ``DAMPFIT_REQUIRE_ALL=1`` is set, as CI does — fails with it, so CI cannot
silently lose coverage. Under ``DAMPFIT_REQUIRE_ALL=1`` every other skip (``pytest.skip``,
``@pytest.mark.skipif``) becomes a failure as well (the hook in ``tests/conftest.py``), except
skips whose reason starts with :data:`OPTIONAL` (use :func:`skip_optional`) for what CI
deliberately does not install (e.g. pyarrow).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

#: The real recordings: ``../shared/data/real`` beside the checkout (SOURCES.md there).
REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"

#: Environment variable that turns skips for a missing dependency into failures (set by CI).
REQUIRE_ALL_ENV = "DAMPFIT_REQUIRE_ALL"
#: Reason prefix of a skip that stays a skip under DAMPFIT_REQUIRE_ALL=1.
OPTIONAL = "optional: "


def require_all() -> bool:
    """Whether missing dependencies must fail the run (``DAMPFIT_REQUIRE_ALL=1``)."""
    return os.environ.get(REQUIRE_ALL_ENV, "").strip() not in ("", "0")


def require(condition: object, reason: str) -> None:
    """Continue if ``condition`` is true; else skip the test with ``reason`` (one line: what
    is missing and how to install it), or fail with it under ``DAMPFIT_REQUIRE_ALL=1``."""
    if condition:
        return
    if require_all():
        pytest.fail(f"{REQUIRE_ALL_ENV}=1 and a dependency is missing: {reason}", pytrace=False)
    pytest.skip(reason)


def skip_optional(reason: str) -> None:
    """Skip for a dependency CI does not install either (stays a skip under REQUIRE_ALL)."""
    pytest.skip(OPTIONAL + reason)
