"""Captions of the campaign figures (several recordings of one damper, issue 12).

:data:`FIGURES` names each figure of a campaign result folder and its caption, read by the report
(:mod:`dampfit.output.report.campaign`) and drawn by :mod:`dampfit.output.figures.campaign`.
The campaign's terminal table is :mod:`dampfit.output.text_campaign`, which also names the tests
(:func:`~dampfit.output.text_campaign.labels`) for the table, the report and the figures alike.
"""

from __future__ import annotations

#: File stem → caption of each campaign figure (the report shows the caption under it).
FIGURES = {
    "forest": "Forest plot of the damping coefficient c of each test: the test alone (own "
              "posterior, thin) and partially pooled by the hierarchical model (thick), each "
              "median with its 90 % interval; outliers in red. Shaded: the 90 % interval of the "
              "population c (dark) and the 90 % predictive interval of c for a new test (light).",
    "added_mass": "Added-mass method: 1/ω_n² [s²] of each test against its added mass Δm [kg] "
                  "(± 1 sd) and the fitted line 1/ω_n² = (m₀ + Δm)/k, which crosses zero at "
                  "Δm = −m₀ (the effective mass, shaded with its 90 % interval).",
}
