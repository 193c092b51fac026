"""Record a free decay straight from a phone running phyphox (``dampfit record``).

* :mod:`.phyphox` — the client of phyphox's remote-access HTTP API (timeouts, retries with
  backoff, bounded answers, ``http://`` only) and the parsers of its answers;
* :mod:`.live` — the release / end-of-decay detector and the live status line (pure NumPy);
* :mod:`.session` — the recording loop and ``recording.csv`` / ``recording.json``;
* :mod:`.experiment` — dampfit's phyphox experiment file (shipped as package data) and its
  QR code.

The command line (:mod:`dampfit.cli.record`) publishes the recording first and then analyses
it into the same folder as ``dampfit analyze`` would.
"""

from dampfit.record.experiment import write_experiment as write_experiment
from dampfit.record.phyphox import PhyphoxClient as PhyphoxClient
from dampfit.record.phyphox import check_url as check_url
from dampfit.record.session import Recorded as Recorded
from dampfit.record.session import record as record
from dampfit.record.session import write_recording as write_recording

