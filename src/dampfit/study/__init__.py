"""A resumable simulation study comparing damping estimators (``dampfit study CONFIG.toml``).

Every scenario of a TOML grid (:mod:`dampfit.study.config`) is simulated ``replicates`` times;
each recording goes through every estimator of :mod:`dampfit.study.registry` (and the
several-mode ones of :mod:`dampfit.study.modal`, compared mode by mode) and is compared with
the truth and with the Cramér–Rao lower bound (:mod:`dampfit.inference.crlb`). Runs execute on Dask
``distributed`` (:mod:`dampfit.study.runner`: a local cluster, or ``scheduler=ADDRESS``),
are stored as they finish (:mod:`dampfit.study.store`) so an interrupted study resumes, and
end in tidy tables, a ranking and figures (:mod:`dampfit.study.tables`,
:mod:`dampfit.study.figures`). The command line is :mod:`dampfit.cli.study`.

A study with a ``[campaign]`` table simulates test campaigns (several recordings of one damper)
instead and analyses each jointly (:func:`dampfit.campaign.analyze_campaign`); its tables give
the coverage of the analysis' intervals (:mod:`dampfit.study.campaign`).

Python use::

    from dampfit.study import load, run_study
    cfg = load("examples/study_ranking.toml")
    result = run_study(cfg, "ranking.study", workers=2)
    result["ranking"]            # pandas DataFrame, best estimator first

A study reads no result folders of ``dampfit analyze`` (it stores its own runs), so it does
not use :mod:`dampfit.result`. Nothing heavy is imported here at the top.
"""

from __future__ import annotations


def load(path, available=None):
    """Read and validate a study file (see :func:`dampfit.study.config.load`); estimator names
    are checked against ``available`` (default: :data:`dampfit.study.registry.ESTIMATORS` and
    the several-mode :data:`dampfit.study.modal.MODE_ESTIMATORS`)."""
    from dampfit.study.config import load as _load

    if available is None:
        from dampfit.study import modal, registry

        available = list(registry.ESTIMATORS) + list(modal.MODE_ESTIMATORS)
    return _load(path, available)


def run_study(cfg, out, **kw):
    """Run or resume a study (see :func:`dampfit.study.runner.run_study`)."""
    from dampfit.study.runner import run_study as _run

    return _run(cfg, out, **kw)
