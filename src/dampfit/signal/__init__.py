"""Signal stage: from a :class:`~dampfit.io.recording.Recording` to the samples that are fitted.

* :mod:`~dampfit.signal.filters` — zero-phase Butterworth band-pass (SciPy SOS) and its gain;
* :mod:`~dampfit.signal.prepare` — stale samples, offset, continuous part, resampling onto a
  regular grid [s], axis choice, clipping and spike masks, band [Hz], the fitted samples
  (raw or decimated), drift basis and the padded arrays the JAX model is compiled for;
* :mod:`~dampfit.signal.spectrum` — dominant frequency [Hz] (periodogram peak with parabolic
  interpolation), default band, amplitude spectrum [m/s²] and noise density [(m/s²)/√Hz];
* :mod:`~dampfit.signal.window` — free-decay window [s]: start after the release, end at the
  noise floor, a rise, an abrupt envelope drop (catch) or an impact.
"""
