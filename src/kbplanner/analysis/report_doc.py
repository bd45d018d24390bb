"""Report documents (report step): sections of text, tables and images, written as HTML and Markdown.

``ReportDoc`` collects content in order; ``html()`` gives one self-contained page (images embedded as
base64 PNG, a small inline stylesheet, no scripts, no external resources), ``markdown(image_dir)``
gives a Markdown file that refers to PNG files written next to it. Text is escaped; nothing in a
report can run code in the browser.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px;
       color: #222; line-height: 1.45; padding: 0 1em; }
h1 { border-bottom: 2px solid #333; padding-bottom: .2em; }
h2 { margin-top: 2em; border-bottom: 1px solid #bbb; }
table { border-collapse: collapse; margin: .8em 0; font-size: 0.88em; }
th, td { border: 1px solid #ccc; padding: .25em .55em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.85em; color: #555; }
.ok { color: #17692b; font-weight: 600; } .bad { color: #a4161a; font-weight: 600; }
.note { background: #f7f7e8; border-left: 4px solid #c9c36a; padding: .4em .8em; }
"""


@dataclass
class _Block:
    kind: str  # "h2", "p", "note", "table", "image", "frame"
    text: str = ""
    columns: Sequence[str] = ()
    rows: Sequence[Sequence[Any]] = ()
    png: bytes = b""
    name: str = ""


@dataclass
class ReportDoc:
    """An ordered document: headings, paragraphs, notes, tables and PNG figures."""

    title: str
    blocks: list[_Block] = field(default_factory=list)

    def heading(self, text: str) -> None:
        """A section heading."""
        self.blocks.append(_Block("h2", text))

    def paragraph(self, text: str) -> None:
        """A paragraph of plain text."""
        self.blocks.append(_Block("p", text))

    def note(self, text: str) -> None:
        """A highlighted note."""
        self.blocks.append(_Block("note", text))

    def table(self, columns: Sequence[str], rows: Sequence[Sequence[Any]], caption: str = "") -> None:
        """A table; numbers are right-aligned."""
        self.blocks.append(_Block("table", caption, columns=columns, rows=rows))

    def image(self, name: str, png: bytes, caption: str) -> None:
        """A PNG figure; ``name`` is its file name in the Markdown version."""
        self.blocks.append(_Block("image", caption, png=png, name=name))

    def frame(self, src: str, caption: str, height_px: int = 640) -> None:
        """An embedded page beside the report (``src`` relative to it), e.g. the 4D playback."""
        self.blocks.append(_Block("frame", caption, name=src, rows=((height_px,),)))

    @property
    def images(self) -> list[tuple[str, bytes]]:
        """(file name, PNG bytes) of every figure."""
        return [(b.name, b.png) for b in self.blocks if b.kind == "image"]

    def html(self) -> str:
        """The whole report as one self-contained HTML page."""
        out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
               f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>",
               f"<h1>{html.escape(self.title)}</h1>"]
        for b in self.blocks:
            if b.kind == "h2":
                out.append(f"<h2>{html.escape(b.text)}</h2>")
            elif b.kind == "p":
                out.append(f"<p>{html.escape(b.text)}</p>")
            elif b.kind == "note":
                out.append(f'<p class="note">{html.escape(b.text)}</p>')
            elif b.kind == "table":
                out.append(_html_table(b))
            elif b.kind == "image":
                data = base64.b64encode(b.png).decode("ascii")
                out.append(f'<figure><img alt="{html.escape(b.text)}" src="data:image/png;base64,{data}">'
                           f"<figcaption>{html.escape(b.text)}</figcaption></figure>")
            elif b.kind == "frame":
                out.append(f'<figure><iframe src="{html.escape(b.name)}" title="{html.escape(b.text)}" '
                           f'style="width:100%;height:{int(b.rows[0][0])}px;border:1px solid #ccc"></iframe>'
                           f'<figcaption>{html.escape(b.text)} '
                           f'(<a href="{html.escape(b.name)}">open alone</a>)'
                           "</figcaption></figure>")
        out.append("</body></html>")
        return "\n".join(out) + "\n"

    def markdown(self, image_prefix: str = "") -> str:
        """The report as Markdown; figures refer to ``{image_prefix}{name}``."""
        out = [f"# {self.title}", ""]
        for b in self.blocks:
            if b.kind == "h2":
                out += [f"## {b.text}", ""]
            elif b.kind == "p":
                out += [b.text, ""]
            elif b.kind == "note":
                out += [f"> {b.text}", ""]
            elif b.kind == "table":
                if b.text:
                    out += [f"*{b.text}*", ""]
                out.append("| " + " | ".join(_md(c) for c in b.columns) + " |")
                out.append("|" + "---|" * len(b.columns))
                out += ["| " + " | ".join(_md(_fmt(v)) for v in r) + " |" for r in b.rows]
                out.append("")
            elif b.kind == "image":
                out += [f"![{b.text}]({image_prefix}{b.name})", "", f"*{b.text}*", ""]
            elif b.kind == "frame":
                out += [f"[{b.text}]({b.name})", ""]
        return "\n".join(out)

    def write(self, directory: Path, stem: str = "report") -> tuple[Path, Path]:
        """Write ``{stem}.html``, ``{stem}.md`` and the figures under ``figures/``; returns both paths."""
        directory = Path(directory)
        for name, png in self.images:
            atomic_write_bytes(directory / "figures" / name, png)
        h, m = directory / f"{stem}.html", directory / f"{stem}.md"
        atomic_write_text(h, self.html())
        atomic_write_text(m, self.markdown("figures/"))
        return h, m


def _fmt(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.2f}"
    return str(v)


def _md(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _html_table(b: _Block) -> str:
    parts = ["<table>"]
    if b.text:
        parts.append(f"<caption>{html.escape(b.text)}</caption>")
    parts.append("<tr>" + "".join(f"<th>{html.escape(str(c))}</th>" for c in b.columns) + "</tr>")
    for r in b.rows:
        cells = []
        for v in r:
            cls = ' class="num"' if isinstance(v, int | float) and not isinstance(v, bool) else ""
            cells.append(f"<td{cls}>{html.escape(_fmt(v))}</td>")
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</table>")
    return "".join(parts)
