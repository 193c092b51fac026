"""Data-logger text exports: a preamble of settings lines before the table.

Stand-alone loggers (CONTEC, Graphtec, HIOKI, Omega …) write their settings first — model,
start time, channel ranges, the sampling interval, one ``key,value`` per line — and then a
table of the channels, often without a time column (the rate is in the preamble or the
manual). The dialect sniffer (:func:`dampfit.io.text.sniff_dialect`) sees the preamble's
ragged lines and finds no table. :func:`strip_preamble` finds the first line from which the
text is a uniform table — a row of names or numbers followed by at least
:data:`MIN_TABLE_ROWS` numeric rows with the same number of separators — and drops the lines
before it, with a note that names how many and quotes a sampling-rate line it saw (the rate is
never taken from it silently: a logger's interval may be per channel or per scan; give it with
``--rate HZ``).
"""

from __future__ import annotations

import re

from dampfit.io.text import is_number

#: Numeric rows that must follow the table's first line for it to count as one.
MIN_TABLE_ROWS = 5
#: Lines looked at for the start of the table.
_SCAN_LINES = 300
_SEPARATORS = ("\t", ";", ",", "|")
_RATE_LINE = re.compile(r"(sampl\w*|scan)[\s_-]*(rate|freq\w*|interval|clock|period|speed)",
                        re.I)


def _numeric(line: str, sep: str) -> bool:
    fields = line.split(sep)
    return all(is_number(f, "," if sep != "," and "," in f else ".") for f in fields) and \
        any(f.strip() for f in fields)


def _table_start(lines: list[str]) -> tuple[int, str] | None:
    """(index of the table's first line, separator), or None if no table follows a preamble."""
    for sep in _SEPARATORS:
        counts = [line.count(sep) for line in lines]
        for k in range(1, len(lines) - MIN_TABLE_ROWS):
            c = counts[k]
            body = lines[k + 1:k + 1 + MIN_TABLE_ROWS]
            if c == 0 or any(n != c for n in counts[k + 1:k + 1 + MIN_TABLE_ROWS]):
                continue
            if all(_numeric(line, sep) for line in body) and counts[k - 1] != c:
                return k, sep
    return None


def strip_preamble(text: str) -> tuple[str, str | None]:
    """``text`` without a logger's preamble, and a note on what was dropped (None: unchanged)."""
    head = text.split("\n", _SCAN_LINES)[:_SCAN_LINES]
    lines = [line.rstrip() for line in head]
    found = _table_start(lines)
    if found is None:
        return text, None
    k, _ = found
    rate = next((line.strip() for line in lines[:k] if _RATE_LINE.search(line)), None)
    note = (f"skipped a {k}-line header before the table (first line {lines[0].strip()[:40]!r})"
            + (f"; it mentions {rate[:60]!r}: give the sample rate with --rate HZ if the table "
               "has no time column" if rate else ""))
    rest = text.split("\n", k)
    return (rest[k] if len(rest) > k else ""), note
