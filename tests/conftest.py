"""Shared fixtures: short simulated recordings and one analysed result per session.

Optional dependencies (``DAMPFIT_REQUIRE_ALL``)
-----------------------------------------------
A test that needs something the machine may lack (OpenSeesPy and its BLAS/LAPACK, Chromium,
the real recordings in ../shared) calls :func:`require` (or uses a fixture built on it such as
``requires_opensees``): it skips with the one-line reason, or — when the environment variable
``DAMPFIT_REQUIRE_ALL=1`` is set, as CI does — fails with it, so CI cannot silently lose
coverage. Under ``DAMPFIT_REQUIRE_ALL=1`` every other skip (``pytest.skip``,
``@pytest.mark.skipif``) becomes a failure as well (hook below), except skips whose reason
starts with :data:`OPTIONAL` (use :func:`skip_optional`) for what CI deliberately does not
install (e.g. pyarrow).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"

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


@pytest.fixture
def requires_opensees():
    """Skip (or fail under DAMPFIT_REQUIRE_ALL=1) unless OpenSeesPy can be imported; the reason
    names the fix (``pip install 'dampfit[fem]'`` or the Debian BLAS/LAPACK packages)."""
    from dampfit.fem.opensees import unavailable

    reason = unavailable()
    require(reason is None, reason or "")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under DAMPFIT_REQUIRE_ALL=1 a skip (other than :func:`skip_optional`) is a failure."""
    outcome = yield
    rep = outcome.get_result()
    if not (rep.skipped and require_all()) or hasattr(rep, "wasxfail"):
        return
    reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
    reason = reason.removeprefix("Skipped: ")
    if reason.startswith(OPTIONAL):
        return
    rep.outcome = "failed"
    rep.longrepr = f"{REQUIRE_ALL_ENV}=1 forbids skipping: {reason}"


@pytest.fixture(scope="session")
def short_paper():
    """A 20 s version of the paper preset: (recording, truth)."""
    from dampfit import simulate as sim  # lazy: keeps collection (and tests/conftest.py) light

    return sim.recording(sim.preset("paper", duration=20.0, seed=7))


@pytest.fixture(scope="session")
def analysed(short_paper):
    """The short paper recording analysed with a known mass ± 0.05 kg."""
    from dampfit import pipeline as analysis

    rec, truth = short_paper
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return analysis.analyze(rec, mass=truth["mass"], mass_sd=0.05, seed=1), truth
