"""Several recordings of one damper analysed jointly (issue 12).

* :mod:`dampfit.campaign.pipeline` — :func:`analyze_campaign`: the stages in order;
* :mod:`dampfit.campaign.tests` — stage 1, each recording on its own (:class:`~dampfit.campaign.tests.TestFit`);
* :mod:`dampfit.campaign.model` — the hierarchical model's log posterior (pure JAX, no I/O);
* :mod:`dampfit.campaign.sampling` — the hyper-posterior sampled with emcee, both frequency
  models, the exact-likelihood importance weights;
* :mod:`dampfit.campaign.checks` — refusals of unusable campaigns and the statistics of the
  verdicts (disagreement, outliers, amplitude explains scatter);
* :mod:`dampfit.campaign.verdict` — the checks stage: the verdict, made once after sampling;
* :mod:`dampfit.campaign.result` — :class:`CampaignAnalysis` (live or loaded: summary, save,
  report), its summary built by :mod:`dampfit.campaign.summary`.

``dampfit.analyze([rec1, rec2, …], …)`` dispatches here.
"""

from dampfit.campaign.pipeline import analyze_campaign
from dampfit.campaign.result import CampaignAnalysis

