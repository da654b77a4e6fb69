"""A one-page, self-contained HTML report (``report.html``): sections of tables, text and PNG
figures embedded as base64 data, one inline style sheet, no script and no network resource, so
the file opens offline, prints and can be sent alone.

The building blocks are small pure functions returning HTML fragments (all text escaped):
:func:`table`, :func:`key_values`, :func:`figure`, :func:`preformatted`; a page is a title and a
list of :class:`Section` written by :func:`write_report`. The run and compare reports
(:mod:`quadmodes.io.run_report`) and any later command (a sweep) use the same API::

    write_report(folder, "sweep of paper-41hz", [Section("results", table(header, rows))])
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from quadmodes._version import __version__
from quadmodes.io.atomic import write_text

__all__ = [
    "REPORT_FILE",
    "Section",
    "figure",
    "figures",
    "format_value",
    "key_values",
    "preformatted",
    "render_report",
    "table",
    "write_report",
]

REPORT_FILE = "report.html"

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Helvetica, Arial, sans-serif;
       max-width: 1100px; margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.35; }
h1 { font-size: 1.5em; margin-bottom: 0.1em; }
h2 { font-size: 1.15em; border-bottom: 1px solid #ccc; padding-bottom: 0.15em; margin-top: 1.4em; }
p.meta { color: #666; margin-top: 0; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #d0d0d0; padding: 0.2em 0.55em; text-align: left; vertical-align: top; }
th { background: #f0f3f7; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
caption { caption-side: top; text-align: left; font-weight: 600; padding-bottom: 0.2em; }
figure { margin: 0.6em 0 1.2em 0; page-break-inside: avoid; }
figure img { max-width: 100%; max-height: 560px; height: auto; border: 1px solid #eee; }
figcaption { color: #555; font-size: 0.85em; }
pre { background: #f7f7f7; padding: 0.6em; overflow-x: auto; font-size: 0.8em; }
.ok { color: #176b2c; font-weight: 600; } .bad { color: #a11; font-weight: 600; }
div.verdict { border: 3px solid #888; border-radius: 6px; padding: 0.5em 1em 0.7em 1em;
              background: #f6f6f6; margin: 0.6em 0 1.2em 0; }
div.verdict.stable { border-color: #2e8b57; background: #eef8f1; }
div.verdict.unstable { border-color: #c0392b; background: #fcf0ee; }
div.verdict p.headline { font-size: 1.15em; font-weight: 700; margin: 0.2em 0 0.5em 0; }
div.verdict table { background: white; width: 100%; }
div.verdict th { width: 15em; }
div.grid { display: grid; grid-template-columns: repeat(auto-fill, minmax(460px, 1fr)); gap: 0 1.2em; }
@media print { body { max-width: none; } h2 { page-break-after: avoid; } }
"""


@dataclass(frozen=True)
class Section:
    """One ``<section>`` of the report: a heading (plain text) and an HTML body fragment (made
    with the functions of this module, whose text is escaped)."""

    title: str
    body: str


def format_value(value, fmt: str = ".6g") -> str:
    """A table cell's text: numbers with ``fmt``, booleans yes/no, None and NaN as "—"."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "—" if not math.isfinite(value) else format(value, fmt)
    return str(value)


def _cell(value, tag: str = "td") -> str:
    numeric = isinstance(value, int | float) and not isinstance(value, bool)
    cls = ' class="num"' if numeric and tag == "td" else ""
    return f"<{tag}{cls}>{html.escape(format_value(value))}</{tag}>"


def table(header: Sequence[str], rows: Iterable[Sequence], caption: str | None = None) -> str:
    """An HTML table: ``header`` strings, ``rows`` of values (numbers right-aligned and
    formatted by :func:`format_value`)."""
    head = "".join(_cell(h, "th") for h in header)
    body = "".join("<tr>" + "".join(_cell(v) for v in row) + "</tr>" for row in rows)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def key_values(pairs: Iterable[tuple[str, object]], caption: str | None = None) -> str:
    """A two-column table ``quantity | value``."""
    return table(("quantity", "value"), [(k, v) for k, v in pairs], caption)


def preformatted(text: str, summary: str | None = None) -> str:
    """``text`` in a ``<pre>`` block, folded in a ``<details>`` element if ``summary``."""
    pre = f"<pre>{html.escape(text)}</pre>"
    if summary is None:
        return pre
    return f"<details><summary>{html.escape(summary)}</summary>{pre}</details>"


def paragraph(text: str, css: str | None = None) -> str:
    """``text`` as a paragraph (``css``: an optional class, "ok" or "bad")."""
    cls = f' class="{css}"' if css else ""
    return f"<p{cls}>{html.escape(text)}</p>"


def figure(path: str | Path, caption: str | None = None) -> str:
    """The PNG file ``path`` embedded as a base64 ``data:`` image, with a caption (default the
    file name); "" if the file does not exist."""
    path = Path(path)
    if not path.is_file():
        return ""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    alt = html.escape(caption or path.name)
    return (f'<figure><img alt="{alt}" src="data:image/png;base64,{data}">'
            f"<figcaption>{alt}</figcaption></figure>")  # fmt: skip


def figures(folder: str | Path, items: Iterable[tuple[str, str]]) -> str:
    """The figures ``(file name, caption)`` of ``folder`` that exist, in order."""
    folder = Path(folder)
    return "".join(figure(folder / name, caption) for name, caption in items)


def render_report(title: str, sections: Sequence[Section], subtitle: str = "") -> str:
    """The whole HTML page: title, a line with the package version and the time of writing
    (UTC), and the sections."""
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    meta = f"quadmodes {__version__}, written {stamp}" + (f" · {subtitle}" if subtitle else "")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p class=\"meta\">{html.escape(meta)}</p>",
    ]
    for s in sections:
        parts.append(f"<section><h2>{html.escape(s.title)}</h2>{s.body}</section>")
    parts.append("</body></html>\n")
    return "\n".join(parts)


def write_report(folder: str | Path, title: str, sections: Sequence[Section],
                 subtitle: str = "") -> Path:  # fmt: skip
    """Write ``folder/report.html`` (atomically) from ``sections``; returns its path."""
    return write_text(Path(folder) / REPORT_FILE, render_report(title, sections, subtitle))
