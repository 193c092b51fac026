"""Result folders read back as plain data: the one validating reader of summary.json
(:mod:`dampfit.result.schema`), bounded reading of the folder's files
(:mod:`dampfit.result.files`, :mod:`dampfit.result.folder`). :func:`dampfit.load` turns what
:func:`~dampfit.result.folder.open_result` read into the result object.

Nothing heavy is imported here (the report reads summaries with the standard library only),
and nothing above: the result classes import this package, not the other way round.
"""

from dampfit.result.schema import SCHEMA_VERSION as SCHEMA_VERSION
from dampfit.result.schema import read_summary as read_summary

