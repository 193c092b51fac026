"""Signal stage: from a :class:`~dampfit.io.recording.Recording` to the samples that are fitted.

* :mod:`~dampfit.signal.filters` — zero-phase Butterworth band-pass (SciPy SOS) and its gain;
* :mod:`~dampfit.signal.prepare` — axis choice, resampling onto a regular grid, dominant
  frequency, band, free-decay window (start after the release, stop at a catch or at the noise
  floor), drift basis and the padded arrays the JAX model is compiled for.
"""
