"""Child Python processes that import nothing from the working folder.

dampfit starts Python children of its own: the figure process of ``dampfit analyze``
(:mod:`dampfit.output.figure_process`), the OpenSees probe and run of ``dampfit verify``
(:mod:`dampfit.fem.opensees`) and the Dask workers of ``dampfit study``
(:mod:`dampfit.cluster`). A plain ``python -c CODE`` puts the working folder first on
its import path (and honours ``PYTHONPATH``, ``PYTHONSTARTUP``, the user's site folder), so a
``json.py`` in the folder a user stands in would run inside the child. Every child is
therefore started by :func:`command`:

* ``python -I`` (isolated mode): no working or script folder on the path, every ``PYTHON*``
  environment variable ignored, no user site folder — while Python starts up, only its own
  standard library and installed packages (``site-packages`` and their ``.pth`` files) can
  be imported;
* then, before anything else is imported, the import path is set to :func:`import_path`:
  this process's ``sys.path`` without the entries that stand for the working folder or the
  folder of the script that started this process. Absolute entries this process got from
  ``PYTHONPATH`` or from a script's own path edits stay, so a checkout run with
  ``PYTHONPATH=<checkout>/src`` starts children that import the same dampfit.

``python -m dampfit`` puts the working folder on the path of the *parent* process by Python's
own rule (as every ``python -m`` does); that process trusts its working folder, but its
children still do not: :func:`import_path` drops the folder. A dampfit that can only be
imported from the working folder (``cd src && python -m dampfit``) therefore runs without its
helpers: the figures are drawn in the main process, ``verify`` and ``study`` report that the
child could not import dampfit.
"""

from __future__ import annotations

import os
import sys


def _same(a: str, b: str | None) -> bool:
    if b is None:
        return False
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def _script_folder() -> str | None:
    """The folder Python put first on this process's path for the script it runs
    (``python script.py``, a console script such as ``dampfit``), else None (``-c``, ``-m``:
    there the first entry is the working folder, which :func:`import_path` drops anyway)."""
    if sys.flags.safe_path:  # -P / -I / PYTHONSAFEPATH: nothing was put there
        return None
    main = sys.modules.get("__main__")
    script = getattr(main, "__file__", None)
    if not isinstance(script, str) or getattr(main, "__spec__", None) is not None:
        return None
    return os.path.dirname(os.path.realpath(script))  # Python resolves links the same way


def import_path(path: list[str] | None = None) -> list[str]:
    """This process's import path (or ``path``) as a child may use it: without relative
    entries (``''``, ``'.'``, ``'src'``: they mean the working folder of whoever reads them),
    without the working folder itself and without the folder of the script that started this
    process; absolute entries keep their order."""
    try:
        cwd = os.getcwd()
    except OSError:  # the working folder was deleted: nothing can equal it
        cwd = None
    script = _script_folder()
    keep = []
    for entry in sys.path if path is None else path:
        if not isinstance(entry, str) or not os.path.isabs(entry):
            continue
        if _same(entry, cwd) or _same(entry, script):
            continue
        if entry not in keep:
            keep.append(entry)
    return keep


def command(code: str, path: list[str] | None = None) -> list[str]:
    """The argument list that runs the Python source ``code`` in an isolated child of this
    interpreter whose import path is :func:`import_path` (module docstring). ``code`` may
    read ``sys.argv[1:]``: append the arguments to the list."""
    boot = f"import sys; sys.path[:] = {import_path(path)!r}\n"
    return [sys.executable, "-I", "-c", boot + code]
