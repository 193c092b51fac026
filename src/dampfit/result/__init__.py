"""Result folders read back: the one validating reader of summary.json
(:mod:`dampfit.result.schema`) and :func:`load` (:mod:`dampfit.result.folder`), which returns the
:class:`dampfit.pipeline.Analysis` a folder was written from (of a campaign folder, several
recordings of one damper: the :class:`dampfit.campaign.analysis.CampaignAnalysis`).

Nothing heavy is imported here (the report reads summaries with the standard library only).
"""

from dampfit.result.folder import load as load
from dampfit.result.schema import SCHEMA_VERSION as SCHEMA_VERSION
from dampfit.result.schema import read_summary as read_summary

__all__ = ["SCHEMA_VERSION", "load", "read_summary"]
