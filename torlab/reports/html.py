"""Report assembly: sections -> figures (PNG; SVG/PDF on request), CSV tables, ``report.html``,
``report.md``.

Every protocol report (:mod:`torlab.reports.amount`, :mod:`~torlab.reports.timetest`,
:mod:`~torlab.reports.traction`, :mod:`~torlab.reports.stribeck`) returns a
:class:`Section`.  :func:`write_sections` writes each section's figures (in the
formats asked for; declared :class:`~torlab.reports.render.Plot` figures are
drawn in parallel and cached by content, :mod:`torlab.reports.render`) and tables
(CSV) into its own sub-folder, then ``report.html`` (figures shown from their files
-- PNG, else SVG --, or embedded as base64 with ``reports.html_figures: embed``;
tables inline, no script) and a ``report.md`` that links the files.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Figure", "Section", "Table", "html_lines", "markdown_lines", "render_html",
           "render_markdown", "write_figures", "write_sections", "write_tables"]


@dataclass
class Figure:
    """A figure of a section: file stem, the figure, caption.

    ``fig`` is a :class:`~torlab.reports.render.Plot` (drawn when needed, cached by
    content) or a finished matplotlib figure.
    """

    name: str
    fig: Any
    caption: str


@dataclass
class Table:
    """A table of a section: CSV name (without ``.csv``), DataFrame, caption.

    ``show`` columns (display name -> (column, format)) are what the HTML and
    Markdown show; the CSV holds every column.  ``allow_missing`` names columns
    where an empty cell means "does not exist" (e.g. no crossing).  Long tables
    (``inline=False``) are only linked from the report.
    """

    name: str
    df: Any
    caption: str
    show: dict[str, tuple[str, str]] | None = None
    allow_missing: tuple[str, ...] = ()
    inline: bool = True


@dataclass
class Section:
    """One report: text, figures, tables and key numbers for ``summary.json``."""

    key: str
    title: str
    paragraphs: list[str] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    images: dict[str, bytes] = field(default_factory=dict)
    image_types: dict[str, str] = field(default_factory=dict)
    figure_files: dict[str, list[str]] = field(default_factory=dict)


def write_figures(dest: Any, sections: list[Section], formats: Any = None, *, store: Any = None,
                  executor: Any = None, ahead: Any = None, images: bool = False) -> Any:
    """Write every section's figures (``<key>/<name>.<format>``); returns the
    :class:`~torlab.reports.render.RenderStats`.

    A figure file of the earlier results (replaced with ``force``) that holds the same
    bytes is kept as it is, not rewritten (:meth:`~torlab.outputs.OutputDir.write_bytes`,
    ``keep_same``).  ``images``: keep the bytes shown in an HTML page that embeds them (PNG,
    else SVG) on the section (:attr:`Section.images`); otherwise only their file names.
    ``ahead``: figures already started (:class:`~torlab.reports.render.FiguresAhead`).
    """
    from torlab.reports.render import DEFAULT_FORMATS, render_figures

    formats = tuple(formats or DEFAULT_FORMATS)
    items = [(f"{s.key}/{f.name}", f.fig) for s in sections for f in s.figures]
    show = next((x for x in ("png", "svg") if x in formats), None)

    def write(name: str, got: dict[str, bytes]) -> bytes | None:
        """Each figure written as soon as it is drawn (none are all held at once)."""
        for fmt in formats:  # an earlier result's file with the same bytes is kept
            dest.write_bytes(f"{name}.{fmt}", got[fmt], keep_same=True)
        return got[show] if images and show is not None else None

    shown, stats = render_figures(items, formats, store=store, executor=executor, ahead=ahead,
                                  each=write)
    for s in sections:
        for f in s.figures:
            names = [f"{s.key}/{f.name}.{fmt}" for fmt in formats]
            if show is not None:
                if images:
                    s.images[f.name] = shown[f"{s.key}/{f.name}"]
                s.image_types[f.name] = show
            s.figure_files[f.name] = names
            s.files += names
    return stats


def write_tables(dest: Any, sections: list[Section]) -> None:
    """Write every section's tables (``<key>/<name>.csv``)."""
    for s in sections:
        for t in s.tables:
            dest.write_csv(f"{s.key}/{t.name}.csv", t.df, allow_missing=t.allow_missing)
            s.files.append(f"{s.key}/{t.name}.csv")


def write_sections(dest: Any, sections: list[Section], formats: Any = None, *, store: Any = None,
                   executor: Any = None) -> Any:
    """Write every section's figures and tables (:func:`write_figures`, :func:`write_tables`);
    returns the figures' :class:`~torlab.reports.render.RenderStats`."""
    stats = write_figures(dest, sections, formats, store=store, executor=executor)
    write_tables(dest, sections)
    return stats


def _fmt(v: Any, fmt: str) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        return format(v, fmt) if fmt else f"{v:.4g}"
    if isinstance(v, (int,)) and fmt and not isinstance(v, bool):
        return format(v, fmt)
    return str(v)


def _rows(t: Table) -> tuple[list[str], list[list[str]]]:
    df = t.df
    show = t.show or {c: (c, "") for c in df.columns}
    heads = list(show)
    rows = []
    for _, r in df.iterrows():
        rows.append([_fmt(r.get(col), fmt) for col, fmt in show.values()])
    return heads, rows


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #444}h2{border-bottom:1px solid #bbb;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0 1.2em;font-size:.88em}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}th{background:#f0f0f0}
td:first-child,th:first-child{text-align:left}
figure{margin:1em 0}figure img{max-width:100%}figcaption{font-size:.9em;color:#444}
.note{color:#8a5a00}.prov{font-size:.8em;color:#555}code{background:#f4f4f4;padding:0 .2em}
"""


def render_html(title: str, intro: list[str], sections: list[Section],
                provenance: dict[str, Any], figures: str | None = "embed") -> str:
    """An HTML page (inline CSS, no script): ``figures="link"`` shows each figure from its
    file (PNG, else SVG) next to the page, so the page's size does not grow with the
    figures; ``"embed"`` puts them into the page as base64 (one self-contained file);
    None: the figures were not drawn and the page names them.  The page is
    :func:`html_lines` joined."""
    return "".join(html_lines(title, intro, sections, provenance, figures))


def html_lines(title: str, intro: list[str], sections: list[Section],
               provenance: dict[str, Any], figures: str | None = "embed") -> Iterator[str]:
    """:func:`render_html`'s page a line at a time (each with its newline), so that it can
    be written without being whole in memory (:meth:`torlab.outputs.OutputDir.write_lines`)."""
    e = html.escape
    yield "<!DOCTYPE html>\n"
    yield "<html lang='en'><head><meta charset='utf-8'>\n"
    yield f"<title>{e(title)}</title><style>{_CSS}</style></head><body>\n"
    yield f"<h1>{e(title)}</h1>\n"
    for p in intro:
        yield f"<p>{e(p)}</p>\n"
    if sections:
        yield "<ul>" + "".join(f"<li><a href='#{e(s.key)}'>{e(s.title)}</a></li>"
                               for s in sections) + "</ul>\n"
    for s in sections:
        yield f"<h2 id='{e(s.key)}'>{e(s.title)}</h2>\n"
        for p in s.paragraphs:
            yield f"<p>{e(p)}</p>\n"
        for n in s.notes:
            yield f"<p class='note'>note: {e(n)}</p>\n"
        for t in s.tables:
            yield f"<p><b>{e(t.caption)}</b> (<code>{e(s.key)}/{e(t.name)}.csv</code>)</p>\n"
            if not t.inline:
                continue
            heads, rows = _rows(t)
            yield "<table><tr>" + "".join(f"<th>{e(h)}</th>" for h in heads) + "</tr>\n"
            for r in rows:
                yield "<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>\n"
            yield "</table>\n"
        for f in s.figures:
            yield _html_figure(s, f, figures) + "\n"
    yield "<h2 id='provenance'>Provenance</h2><div class='prov'><table>\n"
    for k in ("torlab_version", "protocol_file", "protocol_sha256", "command"):
        if k in provenance:
            yield f"<tr><th>{e(k)}</th><td>{e(str(provenance[k]))}</td></tr>\n"
    yield "</table><table><tr><th>input file</th><th>SHA-256</th></tr>\n"
    for name, h in provenance.get("inputs", {}).items():
        yield f"<tr><td>{e(name)}</td><td>{e(h)}</td></tr>\n"
    yield "</table></div></body></html>\n"


def _html_figure(s: Section, f: Figure, figures: str | None) -> str:
    """One figure of the HTML page: linked, embedded, or named when it was not drawn."""
    from urllib.parse import quote

    e = html.escape
    if figures is None or f.name not in s.figure_files:
        return f"<p><b>{e(f.caption)}</b> (figure not drawn: --no-figures)</p>"
    files = s.figure_files[f.name]
    kind = s.image_types.get(f.name)
    links = ", ".join(f"<a href='{e(quote(x, safe='/._-'))}'><code>{e(x)}</code></a>"
                      for x in files)
    shown = next((x for x in files if kind and x.endswith(f".{kind}")), None)
    if shown is None:
        return f"<p><b>{e(f.caption)}</b> ({links})</p>"
    if figures == "embed" and f.name in s.images:
        mime = "image/svg+xml" if kind == "svg" else "image/png"
        src = f"data:{mime};base64,{base64.b64encode(s.images[f.name]).decode('ascii')}"
    else:
        src = quote(shown, safe="/._-")
    return (f"<figure><img alt='{e(f.caption)}' src='{e(src)}' loading='lazy'>"
            f"<figcaption>{e(f.caption)} ({links})</figcaption></figure>")


_MD_SPECIAL = str.maketrans({"\\": "\\\\", "`": "\\`", "[": "\\[", "]": "\\]",
                             "|": "\\|", "<": "&lt;", ">": "&gt;", "&": "&amp;", "\n": " ",
                             "\r": " "})


def md_escape(text: Any) -> str:
    """Text from data (log headers, labels, file names) made inert in Markdown.

    Raw HTML (``<img onerror=...>``) becomes entities, as ``html.escape`` does for
    ``report.html``; the Markdown characters that make links, images, code spans
    and table cells are backslash-escaped (emphasis is harmless and left as
    written, so ``mu_c1`` stays readable), and line breaks become spaces so a
    value cannot start a heading or leave a table row.
    """
    return str(text).translate(_MD_SPECIAL)


def _md_code(text: Any) -> str:
    """Inline code for text from data (backticks cannot close it early)."""
    s = " ".join(str(text).split())
    n = 1
    while "`" * n in s:
        n += 1
    fence = "`" * n
    pad = " " if s.startswith("`") or s.endswith("`") else ""
    return f"{fence}{pad}{s}{pad}{fence}" if s else "—"


def _md_link(path: str) -> str:
    """A link target for a file the report wrote (spaces and parentheses encoded)."""
    from urllib.parse import quote

    return quote(path, safe="/._-")


def render_markdown(title: str, intro: list[str], sections: list[Section],
                    provenance: dict[str, Any], figures: bool = True) -> str:
    """``report.md``: the same content, figures and tables linked as files
    (:func:`markdown_lines` joined).

    Every piece of text is escaped with :func:`md_escape` (the HTML report
    escapes the same text with ``html.escape``).
    """
    return "".join(markdown_lines(title, intro, sections, provenance, figures))


def markdown_lines(title: str, intro: list[str], sections: list[Section],
                   provenance: dict[str, Any], figures: bool = True) -> Iterator[str]:
    """:func:`render_markdown`'s text a line at a time (each with its newline)."""
    e = md_escape
    yield f"# {e(title)}\n\n"
    for p in intro:
        yield f"{e(p)}\n\n"
    for s in sections:
        yield f"## {e(s.title)}\n\n"
        for p in s.paragraphs:
            yield f"{e(p)}\n\n"
        for n in s.notes:
            yield f"> note: {e(n)}\n\n"
        for t in s.tables:
            csv = f"{s.key}/{t.name}.csv"
            yield f"**{e(t.caption)}** ([{e(csv)}]({_md_link(csv)}))\n\n"
            if not t.inline:
                continue
            heads, rows = _rows(t)
            yield "| " + " | ".join(e(h) for h in heads) + " |\n"
            yield "|" + "|".join("---" for _ in heads) + "|\n"
            for r in rows:
                yield "| " + " | ".join(e(c) for c in r) + " |\n"
            yield "\n"
        for f in s.figures:
            if not figures:
                yield f"*{e(f.caption)}* (figure not drawn: --no-figures)\n\n"
                continue
            files = s.figure_files.get(f.name) or [f"{s.key}/{f.name}.png"]
            shown = next((x for x in files if x.endswith((".png", ".svg"))), None)
            if shown is not None:
                yield f"![{e(f.caption)}]({_md_link(shown)})\n\n"
            others = [x for x in files if x != shown]
            more = (" (" + ", ".join(f"[{x.rsplit('.', 1)[1].upper()}]({_md_link(x)})"
                                     for x in others) + ")") if others else ""
            yield f"*{e(f.caption)}*{more}\n\n"
    yield "## Provenance\n\n"
    yield f"- torlab {e(provenance.get('torlab_version', ''))}\n"
    yield (f"- protocol {_md_code(provenance.get('protocol_file', ''))} (SHA-256 "
           f"{_md_code(provenance.get('protocol_sha256', ''))})\n\n")
    yield "| input file | SHA-256 |\n"
    yield "|---|---|\n"
    for k, v in provenance.get("inputs", {}).items():
        yield f"| {e(k)} | {_md_code(v)} |\n"
