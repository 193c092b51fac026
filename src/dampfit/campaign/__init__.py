"""Several recordings of one damper analysed jointly (issue 12).

* :mod:`dampfit.campaign.model` — the hierarchical model's log posterior (pure JAX, no I/O);
* :mod:`dampfit.campaign.checks` — refusals of unusable campaigns and the verdicts
  (disagreement, outliers, amplitude explains scatter);
* :mod:`dampfit.campaign.analysis` — :func:`analyze_campaign` and :class:`CampaignAnalysis`.

``dampfit.analyze([rec1, rec2, …], …)`` dispatches here.
"""

from dampfit.campaign.analysis import CampaignAnalysis, analyze_campaign

__all__ = ["CampaignAnalysis", "analyze_campaign"]
