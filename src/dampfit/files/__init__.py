"""Files dampfit writes and the folders it keeps: the edges on the way out.

* :mod:`~dampfit.files.atomic` — one file written atomically (complete or absent), the umask's
  mode, output-file checks, one-line I/O error text;
* :mod:`~dampfit.files.lock` — :class:`~dampfit.files.lock.FileLock`, the one lock;
* :mod:`~dampfit.files.folder` — :class:`~dampfit.files.folder.ResultFolder`: a whole result
  folder staged, locked, marked and swapped in;
* :mod:`~dampfit.files.swap` — the swap itself (``renameat2(RENAME_EXCHANGE)``, signals held);
* :mod:`~dampfit.files.private` — the private, authenticated folder of the compiled kernels;
* :mod:`~dampfit.files.writers` — the phyphox-style CSV writer and the truth JSON writer.

(Reading goes through the one bounded guard, :mod:`dampfit.io.bounded`.)
"""
