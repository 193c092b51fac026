"""Inference stage: least squares, noise calibration, posterior sampling, evidence and the CRLB.

* :mod:`~dampfit.inference.least_squares` — optimistix Levenberg–Marquardt on θ = (ln p, ln ω_d);
* :mod:`~dampfit.inference.noise` — residual level σ and the Whittle factor r;
* :mod:`~dampfit.inference.posterior` — emcee over θ, mass draws, arviz ``InferenceData``;
* :mod:`~dampfit.inference.sampler_run` — ``SamplerRun``, the one result of every emcee run,
  its stop reason and diagnostics;
* :mod:`~dampfit.inference.law_fit` / :mod:`~dampfit.inference.law_sampler` — fits, Laplace
  evidence and posterior draws of every damping law;
* :mod:`~dampfit.inference.crlb` — the Cramér–Rao bound of a recording design;
* :mod:`~dampfit.inference.executables` — compiled kernels kept on disk between CLI runs.
"""
