"""Many independent recordings in one command: ``dampfit batch`` and
:func:`dampfit.analyze_many`.

* :mod:`.inputs` — the recordings (files, ``--list``, folders), their masses
  (``--mass`` or ``--masses masses.csv``) and reading options: :class:`~.inputs.Job`;
* :mod:`.task` — one recording analysed where it runs (a Dask worker or this process) → one
  row; a refused or failing recording is a row, never the end of the batch;
* :mod:`.store` — the batch folder: ``batch.json`` and the append-only ``rows.jsonl``
  (resumable, locked);
* :mod:`.table` — results.csv/.parquet, summary.md and comparison.png from the rows;
* :mod:`.runner` — :func:`~.runner.run_batch` (here, on a local Dask cluster or an existing
  one) and :func:`~.runner.analyze_many`.
"""

from dampfit.batch.runner import analyze_many, run_batch

