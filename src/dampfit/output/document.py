"""Rendering of report blocks to self-contained HTML and to Markdown (no data logic here).

:mod:`dampfit.output.report` turns a result folder into a list of *blocks* — ``(kind, payload)``
tuples such as headings, paragraphs, tables, figures and notes — and this module renders that
list: :func:`render_html` (figures embedded as base64 ``data:`` URIs, inline CSS, a
Content-Security-Policy that forbids any other resource) and :func:`render_markdown` (figures
as relative PNG links). The first lines of both carry the marker by which a refresh knows
its own report (:data:`dampfit.result.files.REPORT_MARKERS`, defined there with its check).
Standard library and :mod:`dampfit.result.files` only.
"""

from __future__ import annotations

import base64
import html
import os
import re
import struct
from pathlib import Path
from typing import Any

from dampfit.result.files import MAX_FIGURE_BYTES, REPORT_GENERATOR, REPORT_MARKERS, read_optional

#: The generator a report names in its first lines; the markers built from it (by which a
#: refresh tells its own report from a foreign file) are defined once, where they are checked:
#: :data:`dampfit.result.files.REPORT_MARKERS`.
GENERATOR = REPORT_GENERATOR
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

Block = tuple


def read_png(directory: str | os.PathLike, name: str) -> tuple[bytes, int, int] | None:
    """(bytes, width, height) of ``DIR/name.png`` if it is a readable PNG, else None: a regular
    file of the folder (not a link, FIFO or device: :mod:`dampfit.result.files`) of at most
    :data:`~dampfit.result.files.MAX_FIGURE_BYTES`."""
    data, _ = read_optional(Path(directory) / f"{name}.png", MAX_FIGURE_BYTES,
                            "a dampfit figure is below 1 MB")
    if data is None:
        return None
    if len(data) < 24 or data[:8] != PNG_MAGIC or data[12:16] != b"IHDR":
        return None
    w, h = struct.unpack(">II", data[16:24])
    return data, w, h


# ----------------------------------------------------------------------------- renderers
_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,Helvetica,Arial,sans-serif;
 max-width:1240px;margin:1.5em auto;padding:0 1em;color:#1d1d1d;line-height:1.45}
h1{font-size:1.55em}h2{border-bottom:1px solid #bbb;margin-top:1.8em;font-size:1.3em}
h3{font-size:1.1em}h4{font-size:1em;margin:1em 0 .3em}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:.9em;display:block;max-width:100%;
 overflow-x:auto}
th,td{border:1px solid #c8c8c8;padding:.22em .55em;text-align:left;vertical-align:top}
th{background:#f0f0f0}td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.n.iv{white-space:normal}td.n span{white-space:nowrap}
p,li,figcaption,.box{overflow-wrap:anywhere}
.box{border:2px solid;border-radius:4px;padding:.5em 1em;margin:1em 0}
.box ul{margin:.3em 0;padding-left:1.2em}
.bad{border-color:#b3001b;background:#fdecee}.ok{border-color:#2e7d32;background:#edf7ed}
.note{border-color:#999;background:#f6f6f6}.bad>strong{color:#b3001b}
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.88em;color:#444}
code,pre{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.9em}
pre{background:#f4f4f4;padding:.6em;white-space:pre-wrap;word-break:break-all}
@media print{body{max-width:none;margin:0}h2{break-after:avoid}
 figure,.box,table{break-inside:avoid}}
"""
_NUMERIC = re.compile(r"^[-+−\[\]\d.,e± ]+$|^—$")  # right-aligned table cells


def _cell(value: Any, numeric: bool) -> str:
    """One ``<td>``; a numeric cell with an interval (``0.265 [0.237, 0.296]``) may break
    between the value and its interval only, so wide tables fit a 1300 px window."""
    text = str(value)
    if not numeric:
        return f"<td>{_h(text)}</td>"
    head, sep, rest = text.partition(" [")
    if not sep or not head.strip():
        return f"<td class=n>{_h(text)}</td>"
    return f'<td class="n iv"><span>{_h(head)}</span> <span>[{_h(rest)}</span></td>'


def _missing_png(name: str) -> str:
    return (f"{name}.png is not in this folder (the analysis ran with --no-figures, or the file "
            "is unreadable: not a PNG, too large, or a link, FIFO or device, which a report "
            "never follows); re-run the analysis without --no-figures to draw it.")


def _h(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _spans_html(spans: list) -> str:
    tags = {"b": "strong", "i": "em", "code": "code"}
    return "".join(_h(sp) if isinstance(sp, str) else f"<{tags[sp[0]]}>{_h(sp[1])}</{tags[sp[0]]}>"
                   for sp in spans)


def render_html(title: str, blocks: list[Block], directory: str | os.PathLike) -> str:
    """A self-contained HTML page: inline CSS, figures as data URIs, no other resource."""
    directory = Path(directory)
    out = []
    for blk in blocks:
        kind = blk[0]
        if kind in ("h1", "h2", "h3", "h4"):
            out.append(f"<{kind}>{_h(blk[1])}</{kind}>")
        elif kind == "p":
            out.append(f"<p>{_spans_html(blk[1])}</p>")
        elif kind == "ul":
            out.append("<ul>" + "".join(f"<li>{_spans_html(i)}</li>" for i in blk[1]) + "</ul>")
        elif kind == "table":
            head = "".join(f"<th>{_h(c)}</th>" for c in blk[1])
            text_cols = {0} | {j for j, c in enumerate(blk[1]) if c in ("unit", "note")}
            rows = "".join("<tr>" + "".join(
                _cell(c, j not in text_cols and bool(_NUMERIC.match(str(c))))
                for j, c in enumerate(r)) + "</tr>" for r in blk[2])
            out.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>")
        elif kind == "figure":
            name, caption, why = blk[1:]
            png = None if why else read_png(directory, name)
            if png is None:
                out.append(f'<div class="box note"><strong>{_h(name)}.png</strong>: '
                           f"{_h(why or _missing_png(name))}</div>")
                continue
            data, w, h = png
            uri = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
            out.append(f'<figure><img src="{uri}" width="{w}" height="{h}" alt="{_h(caption)}">'
                       f"<figcaption><strong>{_h(name)}.png</strong> — {_h(caption)}"
                       "</figcaption></figure>")
        elif kind == "box":
            _, cls, head, items = blk
            lis = "".join(f"<li>{_spans_html(i)}</li>" for i in items)
            out.append(f'<div class="box {cls}"><strong>{_h(head)}</strong>'
                       f"{'<ul>' + lis + '</ul>' if lis else ''}</div>")
        elif kind == "code":
            out.append(f"<pre><code>{_h(blk[1])}</code></pre>")
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
            f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">\n'
            f'{REPORT_MARKERS["report.html"]}\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{_h(title)}</title><style>{_CSS}</style></head>\n<body>\n"
            + "\n".join(out) + "\n</body></html>\n")


def _md(text: Any) -> str:
    """Markdown-escaped plain text on one line."""
    text = re.sub(r"\s+", " ", str(text))
    return "".join("\\" + ch if ch in "\\`*_[]<>|#~" else ch for ch in text)


def _md_code(text: str) -> str:
    """A Markdown code span that survives backticks and line breaks inside ``text`` (a line
    break would end the span's paragraph and let the rest through as raw HTML)."""
    text = " ".join(text.split())
    ticks = "`" * (max([0] + [len(r) for r in re.findall("`+", text)]) + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{ticks}{pad}{text}{pad}{ticks}"


def _spans_md(spans: list) -> str:
    out = []
    for sp in spans:
        if isinstance(sp, str):
            out.append(_md(sp))
        elif sp[0] == "code":
            out.append(_md_code(str(sp[1])))
        else:  # emphasis markers must touch the text: keep the spaces outside them
            text = _md(sp[1])
            core, mark = text.strip(), "**" if sp[0] == "b" else "*"
            lead, trail = text[: len(text) - len(text.lstrip())], text[len(text.rstrip()):]
            out.append(f"{lead}{mark}{core}{mark}{trail}" if core else text)
    return "".join(out)


def render_markdown(title: str, blocks: list[Block], directory: str | os.PathLike) -> str:
    """Markdown (GitHub flavour); figures are the relative PNG files beside it."""
    directory = Path(directory)
    out = [f"{REPORT_MARKERS['report.md']} from summary.json; "
           "regenerate with 'dampfit report DIR' -->"]
    for blk in blocks:
        kind = blk[0]
        if kind in ("h1", "h2", "h3", "h4"):
            out.append("#" * int(kind[1]) + " " + _md(blk[1]))
        elif kind == "p":
            out.append(_spans_md(blk[1]))
        elif kind == "ul":
            out.append("\n".join("- " + _spans_md(i) for i in blk[1]))
        elif kind == "table":
            rows = [blk[1], ["---"] * len(blk[1])] + [list(r) for r in blk[2]]
            out.append("\n".join("| " + " | ".join(c if c == "---" else _md(c) for c in r) + " |"
                                 for r in rows))
        elif kind == "figure":
            name, caption, why = blk[1:]
            if why or read_png(directory, name) is None:
                out.append(f"> **{name}.png**: {_md(why or _missing_png(name))}")
            else:
                out.append(f"![{_md(caption)}]({name}.png)\n\n*{name}.png — {_md(caption)}*")
        elif kind == "box":
            _, cls, head, items = blk
            mark = {"bad": "⚠ ", "ok": "✓ "}.get(cls, "")
            out.append("\n".join([f"> **{mark}{_md(head)}**"] + ([">"] if items else [])
                                 + [f"> - {_spans_md(i)}" for i in items]))
        elif kind == "code":
            fence = "`" * max(3, max([0] + [len(r) for r in re.findall("`+", blk[1])]) + 1)
            out.append(f"{fence}bash\n{blk[1]}\n{fence}")
    return "\n\n".join(out) + "\n"


# ----------------------------------------------------------------------------- entry points
