"""Outputs rendered from the plain-data summary: text table, figures, HTML/Markdown report.

* :mod:`~dampfit.output.format` — the one honest-digits formatter (a value with its 90 %
  interval) that every table and report prints numbers with;
* :mod:`~dampfit.output.text` / :mod:`~dampfit.output.text_campaign` — the CLI's result table
  of one recording / of a campaign;
* :mod:`~dampfit.output.figures` — PNG figures (matplotlib, Agg); a campaign's in
  :mod:`~dampfit.output.campaign`;
* :mod:`~dampfit.output.report` / :mod:`~dampfit.output.document` — the report and its
  HTML/Markdown writer.
"""
