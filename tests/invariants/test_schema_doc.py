"""The summary.json layout documented in :mod:`dampfit.result.schema`'s docstring is the one
written: a real summary's top-level keys are exactly the documented ones, so a key added,
renamed or dropped on either side fails here.

The documented keys are parsed from the docstring's literal blocks (a top-level key is a line
``    {"key"`` or ``     "key"``; nested keys are indented further).
"""

from __future__ import annotations

import re
import warnings

import pytest

import dampfit
from dampfit.result import schema

#: Heading line of each documented layout in the docstring.
SINGLE = "Top-level keys of one recording's summary"
CAMPAIGN = "Top-level keys of a campaign's summary"
_TOP_KEY = re.compile(r'^    [{ ]"(\w+)"')


def documented_keys(doc: str, heading: str) -> list[str]:
    """The top-level keys of the literal block that follows ``heading`` in ``doc``."""
    lines = doc.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith(heading)), None)
    if start is None:
        raise AssertionError(f"the schema docstring has no block {heading!r}")
    i = start
    while not lines[i].rstrip().endswith("::"):  # the heading may wrap
        i += 1
    keys = []
    for line in lines[i + 1:]:
        if line.strip() and not line.startswith("    "):
            break  # the block ends at the first unindented line
        m = _TOP_KEY.match(line)
        if m:
            keys.append(m.group(1))
    return keys


def test_parser_reads_only_top_level_keys():
    doc = ('Top-level keys of one recording\'s summary::\n\n    {"a": 1,\n     "b": {"c",\n'
           '             "d": 2},\n     "e": 3}\n\nAfter the block "f".\n')
    assert documented_keys(doc, SINGLE) == ["a", "b", "e"]


def test_docstring_documents_both_layouts():
    single = documented_keys(schema.__doc__, SINGLE)
    campaign = documented_keys(schema.__doc__, CAMPAIGN)
    assert single[0] == "schema_version" and "parameters" in single and "kind" not in single
    assert campaign[:2] == ["schema_version", "kind"] and "tests" in campaign
    assert len(set(single)) == len(single) and len(set(campaign)) == len(campaign)


@pytest.mark.heavy
def test_a_real_summary_has_exactly_the_documented_keys(short_paper):
    rec, truth = short_paper
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = dampfit.analyze(rec, mass=truth["mass"], mass_sd=0.05, seed=1, max_steps=300)
    summary = result.summary()
    assert list(summary) == documented_keys(schema.__doc__, SINGLE)
    assert summary["schema_version"] == schema.SCHEMA_VERSION


def test_a_summary_without_mass_has_the_same_keys(short_paper):
    rec, _ = short_paper
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        summary = dampfit.analyze(rec, seed=1, max_steps=300).summary()
    assert list(summary) == documented_keys(schema.__doc__, SINGLE)
    assert set(summary["missing"]) >= {"c", "k", "c_crit"}


@pytest.mark.heavy
def test_a_real_campaign_summary_has_exactly_the_documented_keys():
    from dampfit import simulate as sim

    base = sim.from_modal(1.0, 5.0, 0.01, duration=10.0, sample_rate=100.0)
    recs, _ = sim.campaign(base, n_tests=2, added_mass=[0.0, 0.5], seed=7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        summary = dampfit.analyze(recs, added_mass=[0.0, 0.5], seed=1, max_steps=300,
                                  min_ess=50).summary()
    assert list(summary) == documented_keys(schema.__doc__, CAMPAIGN)
    assert summary["kind"] == "campaign" and summary["added_mass"] is not None


@pytest.mark.parametrize("heading", [SINGLE, CAMPAIGN])
def test_a_drift_would_fail(heading):
    doc = schema.__doc__.replace('"provenance"', '"provenance_renamed"')
    assert "provenance" not in documented_keys(doc, heading)
