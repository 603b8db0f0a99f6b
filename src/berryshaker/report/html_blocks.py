"""The HTML building blocks of the reports (the study's, ``doe analyze``'s, ``calibrate``'s): the page's CSS,
tables that never get wider than the page, embedded figures (base64 PNG), cells written as HTML, and the numbers'
formats in a cell.  Every report module builds its page from these; none of them imports a report module.
"""

from __future__ import annotations

import base64
import contextlib
import contextvars
import hashlib
import re
from pathlib import Path

from berryshaker.user_text import html_text

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#1d2330;line-height:1.45}h1{font-size:1.7em}h2{border-bottom:2px solid #c9d3e0;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em;max-width:100%}td,th{border:1px solid #c9d3e0;
padding:4px 9px;text-align:right;vertical-align:top}th{background:#eef2f7}td.l,th.l{text-align:left}
figure{margin:1em 0}figure img{max-width:min(100%,820px);max-height:640px;width:auto;height:auto;border:1px solid #dde3eb}figcaption{font-size:.9em;color:#4a5568}
details{margin:.6em 0;border-left:3px solid #c9d3e0;padding-left:.7em}summary{cursor:pointer;color:#2b4c7e}
details[open]>summary{margin-bottom:.4em}.appendix{border-top:4px double #c9d3e0;margin-top:3em}
.v-reproduced{background:#e3f6e8}.v-not{background:#fbe4e4}.v-partly{background:#fff5d6}.v-nc{background:#eef}
.small{font-size:.85em;color:#4a5568}code{background:#f3f5f8;padding:0 3px}
.wrap{max-width:100%;overflow-x:auto}td,th{overflow-wrap:break-word}thead{display:table-header-group}
.wide table{font-size:.78em}.wide td,.wide th{padding:2px 4px;overflow-wrap:anywhere}
table.fixed{table-layout:fixed;width:100%}td .ci{display:block;font-size:.85em;color:#4a5568}pre.text{white-space:pre-wrap;overflow-wrap:anywhere;font-size:.8em;background:#f7f9fb;
padding:.5em;max-width:100%;box-sizing:border-box}img,svg{max-width:100%}.nw{white-space:nowrap}
span[class^="v-"]{white-space:nowrap}
@page{size:A4;margin:14mm 12mm}
@media print{
body{max-width:none;margin:0;padding:0;font-size:9.5pt}h1{font-size:15pt}h2{font-size:12.5pt;margin-top:1.2em}
h1,h2,h3{page-break-after:avoid;break-after:avoid}
table{page-break-inside:auto;font-size:8pt;max-width:100%}tr{page-break-inside:avoid;break-inside:avoid}
td,th{padding:2px 4px;-webkit-print-color-adjust:exact;print-color-adjust:exact}
.wrap{overflow:visible}pre.text{font-size:7pt}.wide table{font-size:7pt}.wide td,.wide th{padding:1px 3px}
figure{page-break-inside:avoid;break-inside:avoid}figure img{max-width:100%;max-height:23cm;border:none}
span[class^="v-"]{-webkit-print-color-adjust:exact;print-color-adjust:exact}
details::details-content{content-visibility:visible;display:block}details{border-left:none;padding-left:0}}
"""

#: Columns from which a table is printed in the smaller "wide" style.
WIDE_COLUMNS = 8


#: widest embedded figure (pixels): the figure files are 300 dpi (3000 px for a 10 in figure); the page shows a
#: figure at most 820 CSS px wide, and 1400 px keeps it sharp on a high-density screen and in print (A4: 200 dpi)
EMBED_MAX_PX = 1400


#: the largest page PNG read from the :func:`page_figure_cache` folder (bytes)
MAX_PAGE_PNG_BYTES = 64_000_000

#: folder of the page PNGs already scaled (:func:`page_figure_cache`); None: every figure is scaled anew
_PAGE_CACHE: contextvars.ContextVar = contextvars.ContextVar("page_figure_cache", default=None)


@contextlib.contextmanager
def page_figure_cache(folder: str | Path | None):
    """Inside the block a figure's page PNG (:data:`EMBED_MAX_PX` wide) is read from ``folder`` when the same
    figure file was scaled before, by the same code and imaging library, and stored there when not; None: no
    folder.  The stored PNG is the bytes the scaling gives, so the page is the same either way.

    Parameters
    ----------
    folder : str or Path or None
        A private folder of this user's (the study passes one inside its run cache).

    Yields
    ------
    None
        Inside the block page PNGs are kept in ``folder``.
    """
    token = _PAGE_CACHE.set(None if folder is None else Path(folder))
    try:
        yield
    finally:
        _PAGE_CACHE.reset(token)


def _png_for_page(path: Path) -> bytes:
    """A figure file's PNG, scaled down to :data:`EMBED_MAX_PX` wide for embedding (the file keeps its 300 dpi);
    read from the :func:`page_figure_cache` folder when it holds this figure's."""
    data = Path(path).read_bytes()
    folder = _PAGE_CACHE.get()
    if folder is None:
        return _scaled_png(data)
    import PIL

    from berryshaker.outputs import code_fingerprint, write_bytes_atomic
    from berryshaker.runs.cache import read_own_file

    key = hashlib.sha256(f"{code_fingerprint()}\0{PIL.__version__}\0{EMBED_MAX_PX}\0".encode() + data).hexdigest()
    kept = folder / key[:2] / f"{key}.png"
    stored, _ = read_own_file(kept, MAX_PAGE_PNG_BYTES)  # the run cache's rule: a regular file of this user's
    if stored is not None:
        return stored
    small = _scaled_png(data)
    try:
        kept.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(kept, small)
    except OSError:
        pass  # a page PNG not kept is scaled again next time
    return small


def _scaled_png(data: bytes) -> bytes:
    """The PNG ``data`` scaled down to :data:`EMBED_MAX_PX` wide, 256 colours (as it is when not wider)."""
    import io

    from PIL import Image

    with Image.open(io.BytesIO(data)) as im:
        if im.width <= EMBED_MAX_PX:
            return data
        small = im.convert("RGB").resize((EMBED_MAX_PX, round(im.height * EMBED_MAX_PX / im.width)), Image.Resampling.LANCZOS,
                                          reducing_gap=2.0)
        # 256 colours: a figure's lines, text and fills on white keep their look at a fifth of the bytes
        small = small.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        out = io.BytesIO()
        small.save(out, format="PNG", compress_level=6)
        return out.getvalue()


def _img(path: Path, caption: str) -> str:
    data = base64.b64encode(_png_for_page(path)).decode()
    return (f'<figure><img alt="{html_text(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html_text(caption)}</figcaption></figure>")


def _details(summary: str, parts: list[str]) -> str:
    """Folded content: ``parts`` under a one-line ``summary`` the reader opens (printed open: the CSS's print
    rule shows every fold's content).  Empty parts give nothing."""
    body = "\n".join(p for p in parts if p)
    if not body:
        return ""
    return f"<details><summary>{html_text(summary)}</summary>{body}</details>"


def _maybe_img(parts: list, path: Path, caption: str) -> None:
    if Path(path).exists():
        parts.append(_img(path, caption))


def _table(header, rows, left=(0,), widths=None) -> str:
    """A table in a div that never gets wider than the page: ``widths`` (percent per column) fixes the columns'
    shares (long texts wrap inside them); tables of :data:`WIDE_COLUMNS` columns or more print smaller."""
    cols = "" if widths is None else "<colgroup>" + "".join(f"<col style='width:{w:g}%'>" for w in widths) + "</colgroup>"
    h = "".join(f'<th class="{"l" if i in left else ""}">{c if isinstance(c, _Raw) else html_text(str(c))}</th>'
                for i, c in enumerate(header))
    body = []
    for r in rows:
        body.append("<tr>" + "".join(
            f'<td class="{"l" if i in left else ""}">{c if isinstance(c, _Raw) else html_text(_fmt(c))}</td>'
            for i, c in enumerate(r)) + "</tr>")
    wide = " wide" if len(header) >= WIDE_COLUMNS else ""
    cls = " class='fixed'" if widths is not None else ""
    return (f"<div class='wrap{wide}'><table{cls}>{cols}<thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody>"
            "</table></div>")


class _Raw(str):
    pass


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _plain(text: str) -> str:
    """Python's True/False in a sentence read "yes"/"no" in the report."""
    return re.sub(r"\bFalse\b", "no", re.sub(r"\bTrue\b", "yes", str(text)))



def _num(v: float) -> str:
    """Four significant digits, whole numbers from 10 000 on (no "1.005e+04" in a table)."""
    return f"{v:.0f}" if abs(v) >= 1e4 else f"{v:.4g}"

