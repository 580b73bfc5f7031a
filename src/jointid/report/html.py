"""A self-contained HTML report: sections with paragraphs, tables and embedded PNG figures.

The page has no external resources (figures are base64 data URIs, CSS inline),
so it opens offline and can be mailed as one file.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from typing import Sequence

__all__ = ["Table", "Section", "render_report"]


@dataclass(frozen=True)
class Table:
    """A table: a caption, a header and rows of already formatted cells."""

    caption: str
    header: Sequence[str]
    rows: Sequence[Sequence[str]]


@dataclass(frozen=True)
class Section:
    """A report section: title, paragraphs, a bulleted list, tables and figures (name, PNG bytes, caption).

    ``items`` (short statements) are drawn as a list after the paragraphs, then
    ``lists``, titled lists (e.g. ``(("What to trust", [...]), ("What not to trust", [...]))``);
    an empty titled list is left out. A figure's ``name`` is its file: ``"x.png"`` (a
    path relative to the report) as given, a bare name ``"x"`` as ``figures/x.png``.
    """

    title: str
    anchor: str
    paragraphs: Sequence[str] = ()
    tables: Sequence[Table] = ()
    figures: Sequence[tuple[str, bytes, str]] = field(default_factory=tuple)
    items: Sequence[str] = ()
    lists: Sequence[tuple[str, Sequence[str]]] = ()


_CSS = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; max-width: 1100px;
       margin: 2em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
caption { text-align: left; font-weight: bold; padding-bottom: .3em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: right; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: .9em; color: #555; }
.meta { color: #666; font-size: .9em; }
li { margin: .2em 0; }
nav ul { columns: 2; }
"""


def _table_html(t: Table) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in t.header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in t.rows)
    return f"<table><caption>{html.escape(t.caption)}</caption><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def render_report(title: str, meta: str, sections: Sequence[Section]) -> str:
    """The HTML page (a string) for ``sections``; figures are embedded as base64 PNG, the CSS inline.

    The page references nothing outside itself (no scripts, style sheets,
    fonts or image files), so it opens offline and can be mailed as one file.
    """
    nav = "".join(f'<li><a href="#{s.anchor}">{html.escape(s.title)}</a></li>' for s in sections)
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p class='meta'>{html.escape(meta)}</p><nav><ul>{nav}</ul></nav>",
    ]
    for s in sections:
        parts.append(f"<section id='{s.anchor}'><h2>{html.escape(s.title)}</h2>")
        parts.extend(f"<p>{html.escape(p)}</p>" for p in s.paragraphs)
        if s.items:
            parts.append("<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in s.items) + "</ul>")
        for heading, entries in s.lists:
            if entries:
                parts.append(f"<h3>{html.escape(heading)}</h3><ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in entries) + "</ul>")
        parts.extend(_table_html(t) for t in s.tables)
        for name, png, caption in s.figures:
            data = base64.b64encode(png).decode("ascii")
            file = name if name.endswith(".png") else f"figures/{name}.png"
            parts.append(
                f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,{data}'>"
                f"<figcaption>{html.escape(caption)} ({html.escape(file)})</figcaption></figure>"
            )
        parts.append("</section>")
    parts.append("</body></html>")
    return "\n".join(parts)
