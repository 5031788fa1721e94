"""Checks of the pages a person looks at: well-formed, self-contained HTML whose images decode
(:func:`check_page`), and the same page rendered by headless Chromium (:func:`render`): no
script error, no resource that failed to load, every image drawn, nothing wider than the window,
and a screenshot that is not blank."""

from __future__ import annotations

import base64
import html
import io
import json
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np

PNG = b"\x89PNG\r\n\x1a\n"
VOID = {"meta", "img", "br", "hr", "link", "input", "col", "area", "base", "source", "wbr"}
WINDOW_PX = (1280, 900)


class Checker(HTMLParser):
    """Collects images and links; checks that every non-void element is closed in order."""

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.images, self.refs, self.text = [], [], [], [], []
        self.doctype = None

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        for k in ("src", "href"):
            if k in a:
                self.refs.append(a[k])
        if tag not in VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
        else:
            self.stack.pop()

    def handle_data(self, data):
        self.text.append(data)


def check_page(page: str) -> Checker:
    """A report page: one HTML document, elements closed in order, nothing fetched from elsewhere,
    every image a PNG of more than 200 x 200 pixels that is not blank."""
    c = Checker()
    c.feed(page)
    c.close()
    assert c.doctype and c.doctype.lower() == "doctype html"
    assert c.errors == [] and c.stack == []
    assert c.images, "no images"
    for ref in c.refs:  # self-contained: nothing fetched from elsewhere
        assert ref.startswith("data:image/png;base64,"), ref[:60]
    import matplotlib.image as mpimg

    for img in c.images:
        assert img.get("alt")
        raw = base64.b64decode(img["src"].split(",", 1)[1], validate=True)
        assert raw[:8] == PNG
        pixels = mpimg.imread(io.BytesIO(raw), format="png")
        assert pixels.shape[0] > 200 and pixels.shape[1] > 200
        assert float(np.std(pixels)) > 0.01  # not a blank image
    return c


def browser() -> str | None:
    """The headless Chromium to render with, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


# Injected as the first element of <head>: records script errors, console.error calls and
# resources that failed to load, then (after the load event) what the page drew.
_PROBE = """<script>
window.__umbmark = [];
window.addEventListener("error", function (e) {
  var t = e.target;
  window.__umbmark.push(t && t !== window ? "failed to load: " + (t.src || t.href || t.tagName)
                                          : "script error: " + e.message);
}, true);
(function () {
  var ce = console.error;
  console.error = function () {
    window.__umbmark.push("console.error: " + Array.prototype.join.call(arguments, " "));
    return ce.apply(console, arguments);
  };
})();
window.addEventListener("load", function () { setTimeout(function () {
  var imgs = Array.prototype.slice.call(document.images);
  var r = {errors: window.__umbmark, images: imgs.length,
    broken: imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
                .map(function (i) { return i.alt || i.src.slice(0, 80); }),
    scroll_width: document.documentElement.scrollWidth, window_width: window.innerWidth,
    title: document.title, text: document.body.innerText.length};
  var pre = document.createElement("pre");
  pre.id = "umbmark-probe";
  pre.textContent = JSON.stringify(r);
  document.body.appendChild(pre);
}, 500); });
</script>"""


def _chromium(args: list[str], profile: Path, timeout_s: float = 120) -> subprocess.CompletedProcess:
    cmd = [
        browser(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        f"--user-data-dir={profile}",
        *args,
    ]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)


def render(page: Path, work: Path, url: str | None = None, shot_height_px: int = 2400) -> dict:
    """Render ``page`` (a file, next to its assets) in headless Chromium at 1280 px wide.

    A copy with the probe injected is rendered beside it (removed afterwards), from the file or
    from ``url``, the address at which a server serves ``page`` (the copy's address is the same
    with the copy's name). Returns what the probe found (``errors``, ``images``, ``broken``,
    ``scroll_width``, ``window_width``, ``title``, ``text``) and ``shot``, the path of a
    screenshot (under ``work``).
    """
    src = page.read_text(encoding="utf-8")
    m = re.search(r"<head[^>]*>", src, flags=re.I)
    assert m, f"{page}: no <head>"
    probed = page.with_name(f".probe-{page.name}")
    probed.write_text(src[: m.end()] + _PROBE + src[m.end() :], encoding="utf-8")
    if url is None:
        probe_url, page_url = probed.as_uri(), page.as_uri()
    else:
        base = url if url.endswith("/") else url.rsplit("/", 1)[0] + "/"
        probe_url, page_url = base + probed.name, url
    try:
        w, h = WINDOW_PX
        out = _chromium(
            [f"--window-size={w},{h}", "--virtual-time-budget=8000", "--dump-dom", probe_url],
            work / "profile-dom",
        )
        found = re.search(r'<pre id="umbmark-probe">(.*?)</pre>', out.stdout, flags=re.S)
        assert found, f"{page}: the page did not finish loading in Chromium: {out.stderr[-800:]}"
        result = json.loads(html.unescape(found.group(1)))
        shot = work / (re.sub(r"[^A-Za-z0-9]+", "-", "-".join(page.resolve().parts[-2:])).strip("-") + ".png")
        _chromium([f"--window-size={w},{shot_height_px}", f"--screenshot={shot}", page_url], work / "profile-shot")
        result["shot"] = shot
        return result
    finally:
        probed.unlink(missing_ok=True)


def assert_rendered(result: dict, min_images: int = 1) -> None:
    """What a person would see as broken: errors, missing images, a page wider than the window,
    a blank screenshot."""
    assert result["errors"] == [], result["errors"]
    assert result["images"] >= min_images, result
    assert result["broken"] == [], result["broken"]
    assert result["scroll_width"] <= result["window_width"], result
    shot = result["shot"]
    assert shot.read_bytes()[:8] == PNG, "no screenshot"
    import matplotlib.image as mpimg

    px = mpimg.imread(shot)[..., :3]
    assert px.shape[1] == WINDOW_PX[0]
    ink = px.mean(axis=-1) < 0.6
    assert ink.mean() > 0.005, "the screenshot is blank"
