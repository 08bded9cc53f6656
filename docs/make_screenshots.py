"""Screenshots of the report of `squeezebench reproduce` at 1280 and 390 px, for docs/screenshots/.

    python docs/make_screenshots.py [--run RUN_DIR]    # default: reproduce into a temporary folder

Renders RUN_DIR/report/index.html in headless Chromium (/usr/bin/chromium or $CHROMIUM)
inside an iframe exactly as wide as the screen it stands for (Chromium's own window is
never narrower than 500 px, a phone is 390), measures where each part of the page is (a
small script writes the measurements into the outer page, read back with --dump-dom),
takes one screenshot of the whole page per width and cuts it into: the top, Tables 3-5,
Fig. 9, the audit and the accuracy study at 1280 px, and the top and
Tables 3-4 at 390 px. `measure` is also what the browser test
(tests/test_report_browser.py) asserts on.
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

WIDTH_PX = 1280
PHONE_WIDTH_PX = 390
SCREENSHOTS = Path(__file__).resolve().parent / "screenshots"

#: Writes, once the page and its images have loaded, every image's, table's and
#: figure's box and whether each figure has a caption into <pre id="measurements">. An image
#: not yet complete at the window's load event is waited for (its own load or error, at most
#: IMAGE_WAIT_MS of the virtual time). About one suite run in 15, one of the two frames, which
#: load the same files in one Chromium, counted a figure as not loaded at its load event while
#: the other frame had it (the report's and the design page's tests): an image still loading
#: then is now measured once it has. A promise (`img.decode()`) is not waited for under
#: --virtual-time-budget: the page was dumped before it resolved, so events and a timer are.
IMAGE_WAIT_MS = 3000
_MEASURE_JS = """
<script>
(() => {
const measure = () => {
  const box = el => { const r = el.getBoundingClientRect();
    return {left: r.left, right: r.right, width: r.width, top: r.top + window.scrollY, height: r.height}; };
  const appendix = document.querySelector('section.appendix');
  const out = {frame_width: window.frameElement ? Number(window.frameElement.dataset.width) : null,
               viewport: document.documentElement.clientWidth,
               scroll_width: document.documentElement.scrollWidth,
               page_height: document.documentElement.scrollHeight,
               appendix_top: appendix ? box(appendix).top : document.documentElement.scrollHeight,
               images: [...document.images].map(img => ({src: img.getAttribute('src'), loaded: img.complete && img.naturalWidth > 0,
                        caption: (img.closest('figure') && img.closest('figure').querySelector('figcaption')
                                  ? img.closest('figure').querySelector('figcaption').textContent.trim() : ''), ...box(img)})),
               // a wide table scrolls inside its own box: that box is what must fit the page
               tables: [...document.querySelectorAll('table')].map(t => ({caption: t.caption ? t.caption.textContent.trim() : '',
                        text: t.textContent, cells: [...t.querySelectorAll('td')].map(td => td.textContent),
                        ...box(t.closest('.wide') || t)})),
               // the opening sentences, the round trips' cells and every word a reader can see
               opening: document.querySelector('.opening') ? document.querySelector('.opening').textContent : '',
               round_trips: [...document.querySelectorAll('td.trip')].map(td => td.textContent),
               text: (() => { const b = document.body.cloneNode(true);
                              b.querySelectorAll('script,style').forEach(e => e.remove()); return b.textContent; })(),
               sections: Object.fromEntries([...document.querySelectorAll('section[id], figure[id]')].map(s => [s.id, box(s)]))};
  const target = window.parent !== window ? window.parent.document : document;
  const pre = target.createElement('pre');
  pre.id = 'measurements';
  pre.textContent = JSON.stringify(out);
  target.body.appendChild(pre);
};
window.addEventListener('load', () => {
  const pending = [...document.images].filter(img => !img.complete);
  let left = pending.length, written = false;
  const once = () => { if (!written) { written = true; measure(); } };
  if (!left) { once(); return; }
  pending.forEach(img => { const settled = () => { if (--left === 0) once(); };
                           img.addEventListener('load', settled); img.addEventListener('error', settled); });
  setTimeout(once, IMAGE_WAIT_MS);   // an image that never settles is measured as it is
});
})();
</script>
""".replace("IMAGE_WAIT_MS", str(IMAGE_WAIT_MS))


def chromium() -> str:
    """The Chromium binary; FileNotFoundError names how to install it."""
    for candidate in (os.environ.get("CHROMIUM"), "/usr/bin/chromium", shutil.which("chromium"),
                      shutil.which("chromium-browser"), shutil.which("google-chrome")):
        if candidate and Path(candidate).is_file():
            return candidate
    raise FileNotFoundError("no Chromium found (set $CHROMIUM, or: apt-get install -y chromium)")


def _run_chromium(arguments: list[str], timeout_s: float = 120.0) -> str:
    with tempfile.TemporaryDirectory() as profile:
        command = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                   "--no-first-run", "--disable-background-networking", "--disable-component-update",
                   "--disable-sync", "--hide-scrollbars", "--allow-file-access-from-files",
                   f"--user-data-dir={profile}", *arguments]
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, check=True)
    return done.stdout


def _framed(page: Path, widths_px: tuple[int, ...], height_px: int) -> Path:
    """An outer page holding `page` in one iframe per width, side by side, each exactly as
    wide as its screen: the report's own viewports."""
    frame = page.with_name(f".frame{'-'.join(map(str, widths_px))}.html")
    frames = "".join(f"<iframe src='{page.name}' data-width='{width_px}' style='width:{width_px}px;"
                     f"height:{height_px}px;border:0;display:inline-block;vertical-align:top'></iframe>"
                     for width_px in widths_px)
    frame.write_text(f"<!DOCTYPE html><html><body style='margin:0;white-space:nowrap'>{frames}</body></html>")
    return frame


def measure(index: Path, width_px: int = WIDTH_PX) -> dict:
    """Boxes of the rendered report in a `width_px` viewport (see _MEASURE_JS)."""
    return measure_widths(index, (width_px,))[width_px]


def measure_widths(index: Path, widths_px: tuple[int, ...]) -> dict[int, dict]:
    """{width: `measure` at that width}, every width in one Chromium (a start of the browser
    is most of a measurement's time)."""
    index = Path(index)
    probe = index.with_name(".measure.html")   # beside index.html, so its images resolve
    probe.write_text(index.read_text().replace("</body>", _MEASURE_JS + "</body>"))
    frame = _framed(probe, widths_px, 1000)
    try:
        dom = _run_chromium([f"--window-size={sum(max(w, 500) for w in widths_px) + 20},1100",
                             "--virtual-time-budget=10000", "--dump-dom", frame.as_uri()])
    finally:
        probe.unlink()
        frame.unlink()
    measured = {}
    for text in re.findall(r'<pre id="measurements">(.*?)</pre>', dom, flags=re.DOTALL):
        boxes = json.loads(html.unescape(text))
        measured[boxes.pop("frame_width")] = boxes
    missing = set(widths_px) - set(measured)
    if missing:
        raise RuntimeError(f"Chromium measured no page at {sorted(missing)} px")
    return measured


def _page_image(index: Path, width_px: int, height_px: int):
    """The whole report at `width_px` as one image."""
    from PIL import Image   # Pillow comes with matplotlib

    frame = _framed(Path(index), (width_px,), height_px)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            page = Path(tmp) / "page.png"
            _run_chromium([f"--window-size={max(width_px, 500)},{height_px}", "--virtual-time-budget=10000",
                           f"--screenshot={page}", frame.as_uri()])
            image = Image.open(page)
            image.load()
    finally:
        frame.unlink()
    return image.crop((0, 0, width_px, image.height))


def screenshots(index: Path, out_dir: Path = SCREENSHOTS) -> list[Path]:
    """The views a reader checks first, as PNGs under `out_dir`."""
    boxes = measure(index)
    image = _page_image(index, WIDTH_PX, int(boxes["page_height"]))
    sections = boxes["sections"]
    fig9 = next(img for img in boxes["images"] if img["src"] == "fig9.png")
    fig9_figure = max((s for s in sections.values() if s["top"] <= fig9["top"] <= s["top"] + s["height"]
                       and s["height"] < 2000), key=lambda s: s["top"])
    study = sections["study"]
    views = {
        "report_top.png": (0, 1100),
        "report_tables_3_5.png": (sections["table3"]["top"] - 10,
                                  sections["table5"]["top"] + min(sections["table5"]["height"], 1100)),
        "report_fig9.png": (fig9_figure["top"] - 10, fig9_figure["top"] + fig9_figure["height"] + 190),   # and the sentence beneath
        "report_audit.png": (sections["audit"]["top"] - 10, sections["audit"]["top"] + 1300),
        # coverage and the floors the instruments' errors leave, with and without calibration
        "report_study.png": (study["top"] - 10, study["top"] + study["height"] + 10),
    }
    phone = measure(index, PHONE_WIDTH_PX)
    phone_image = _page_image(index, PHONE_WIDTH_PX, int(phone["page_height"]))
    phone_views = {
        "report_top_390.png": (0, 1800),
        "report_tables_3_4_390.png": (phone["sections"]["table3"]["top"] - 10,
                                      phone["sections"]["table4"]["top"] + phone["sections"]["table4"]["height"]),
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for picture, cuts in ((image, views), (phone_image, phone_views)):
        for name, (top, bottom) in cuts.items():
            crop = picture.crop((0, max(0, int(top)), picture.width, min(picture.height, int(bottom))))
            crop.save(out_dir / name, optimize=True)
            written.append(out_dir / name)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, help="a run directory with its report (default: reproduce anew)")
    args = parser.parse_args()
    run_dir = args.run.resolve() if args.run else None   # a file URI needs an absolute path
    if run_dir is None:
        run_dir = Path(tempfile.mkdtemp()) / "paper"
        subprocess.run(["squeezebench", "reproduce", "--out", str(run_dir)], check=True)
    for path in screenshots(run_dir / "report" / "index.html"):
        print(path)


if __name__ == "__main__":
    main()
