"""What a live result and a result loaded from its folder share (no heavy imports).

:class:`dampfit.analysis.Analysis` (one recording) and
:class:`dampfit.campaign.result.CampaignAnalysis` (several) are live when ``analyze``
returned them and loaded when :func:`dampfit.load` did (``_loaded`` set): then the posterior
comes from posterior.nc and the convergence from summary.json, never from a live sampler.
"""

from __future__ import annotations


class ResultViews:
    """``posterior`` and ``converged`` of a live or loaded result; a subclass has the fields
    ``_loaded`` and ``sampling`` and says what converged means when live
    (:meth:`_live_converged`)."""

    @property
    def posterior(self):
        """The posterior as arviz ``InferenceData`` (of a loaded result: posterior.nc)."""
        if self._loaded is not None:
            return self._loaded.posterior()
        return self.sampling.idata

    @property
    def converged(self) -> bool:
        """Whether the result converged (of a loaded result: what its summary says)."""
        if self._loaded is not None:
            return bool(self._loaded.converged())
        return bool(self._live_converged())

    def _live_converged(self) -> bool:  # pragma: no cover - every result class defines it
        raise NotImplementedError
