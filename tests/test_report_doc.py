"""Report documents are self-contained, escaped HTML and matching Markdown."""

from __future__ import annotations

from pathlib import Path

from kbplanner.analysis.report_doc import ReportDoc

PNG = b"\x89PNG\r\n\x1a\nfake"


def test_html_embeds_images_escapes_text_and_refers_to_nothing_outside(tmp_path: Path) -> None:
    doc = ReportDoc("Run <1>")
    doc.heading("Durations")
    doc.paragraph("a <script>alert(1)</script> b")
    doc.table(["frame", "seconds"], [("F01", 251.5), ("F02", None)], caption="per frame")
    doc.image("d.png", PNG, "distance")
    page = doc.html()
    assert "<script>" not in page and "&lt;script&gt;" in page
    assert "data:image/png;base64," in page
    assert "http://" not in page and "https://" not in page
    assert '<td class="num">251.50</td>' in page
    h, m = doc.write(tmp_path)
    assert (tmp_path / "figures" / "d.png").read_bytes() == PNG
    md = m.read_text()
    assert "![distance](figures/d.png)" in md
    assert "| F01 | 251.50 |" in md
    assert h.read_text() == page
