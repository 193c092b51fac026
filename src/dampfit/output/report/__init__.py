"""The damping report of a result folder: ``report.html`` (self-contained) and ``report.md``.

``dampfit report DIR`` (:mod:`dampfit.cli.report`) or :func:`write_report` reads
``DIR/summary.json`` (through the one reader of result folders,
:func:`dampfit.result.schema.read_summary`) — plus the optional ``DIR/verification.json`` and
the PNG figures already in ``DIR`` — and renders them; nothing is recomputed, so the report
states exactly the numbers of ``summary.json``. The package imports only the standard library
and dampfit's own plain-data modules: no JAX, no matplotlib.

* ``report.html`` embeds every figure as a base64 ``data:`` URI with inline CSS and a
  Content-Security-Policy that forbids any other resource: it opens offline and prints.
* ``report.md`` refers to the figures as relative PNG files in ``DIR``.

Both are built from one list of blocks (:func:`build`), so they always say the same thing.
Optional summary entries (``crlb``, ``model_checks``, ``amplitude_curve``, verification) are
shown when present and otherwise say "not computed" with the command that computes them;
entries whose layout the report does not know are rendered as generic tables.

The modules, by concern:

* :mod:`~dampfit.output.report.values` — summary values as text (digits from the one
  formatter :mod:`dampfit.output.format`), labels, units, generic tables;
* :mod:`~dampfit.output.report.single` and :mod:`~dampfit.output.report.checks` — the report
  of one recording (its model checks apart);
* :mod:`~dampfit.output.report.modes` — the section on several modes (one row per mode in
  every damping convention, P(K), close pairs, Rayleigh α, β);
* :mod:`~dampfit.output.report.campaign` — the report of a campaign folder;
* :mod:`~dampfit.output.report.reproduce` — the command that re-creates the folder;
* :mod:`~dampfit.output.report.build` — reading the folder, choosing the report, writing it;
* :mod:`dampfit.output.document` renders the blocks to HTML and Markdown.

Regenerating a report is harmless (it is a pure rendering of the folder), so an existing
report written by dampfit is replaced without ``--force``; ``--force`` is needed only to
replace a ``report.html``/``report.md`` that dampfit did not write.
"""

from dampfit.output.document import GENERATOR as GENERATOR
from dampfit.output.document import PNG_MAGIC as PNG_MAGIC
from dampfit.output.document import render_html as render_html
from dampfit.output.document import render_markdown as render_markdown
from dampfit.output.report.build import build as build
from dampfit.output.report.build import load as load
from dampfit.output.report.build import write_report as write_report
from dampfit.output.report.reproduce import campaign_reproduce_command as campaign_reproduce_command
from dampfit.output.report.reproduce import reproduce_command as reproduce_command

