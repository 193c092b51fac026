"""Outputs rendered from the plain-data summary: text table, figures, HTML/Markdown report.

* :mod:`~dampfit.output.text` — the CLI's result table;
* :mod:`~dampfit.output.figures` — PNG figures (matplotlib, Agg);
* :mod:`~dampfit.output.report` / :mod:`~dampfit.output.document` — the report and its
  HTML/Markdown writer.
"""
