"""The pages a person looks at, rendered in headless Chromium: the reports (an analysis, a
self-calibration, a robot's history) and the documentation site (served over HTTP, as it is
read). No script error, no resource that fails to load, every image drawn, nothing wider than a
1280 px window, a screenshot that is not blank. Without Chromium those checks skip and say why;
the site's links and its API pages' cross-references are checked without a browser.

The site is the one ``.ci/run`` built (``UMBMARK_DOCS_SITE``), else built here. With
``UMBMARK_SCREENSHOTS=DIR`` the screenshots are kept in DIR to be looked at.
"""

import contextlib
import functools
import http.server
import io
import json
import math
import os
import re
import shutil
import subprocess
import sys
import threading
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from pages import assert_rendered, browser, check_page, render

REPO = Path(__file__).resolve().parents[1]
needs_browser = pytest.mark.skipif(browser() is None, reason="no headless Chromium installed (Debian: chromium)")


def _keep(result: dict) -> None:
    keep = os.environ.get("UMBMARK_SCREENSHOTS")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(result["shot"], Path(keep) / result["shot"].name)


# -- the reports ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """An analysis report, the pages of a self-calibration (a differential drive's and a mecanum
    robot's), a calibration loop and a gyro result, and a history page."""
    pytest.importorskip("rosbags")
    from umbmark.cli import main
    from umbmark.correct.analysis import analyze
    from umbmark.history import record_analysis
    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import Command, Program, SimRobot, mixed_program, simulate_drive, simulate_gyro
    from umbmark.model.geometry import FIG11_ERRORS, LABMATE, ErrorParams
    from umbmark.model.sensors import Gyro, Lidar, SensorPose
    from umbmark.model.simulate import simulate_umbmark
    from umbmark.viz.report import analysis_report

    tmp = tmp_path_factory.mktemp("pages")
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=1)
    a = analyze(runs, 4.0, 0.34)
    after = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=2, calibration=a.correction.calibration)
    (tmp / "analysis.html").write_text(analysis_report(a, title="analysis", after_runs=after))
    robot = SimRobot(
        nominal=LABMATE,
        errors=ErrorParams(ed=1.008, eb=1.02, es=1.0),
        sensor_pose=SensorPose(0.10, 0.02, math.radians(-3.0)),
        lidar=Lidar(n_beams=180, range_noise_m=0.003),
    )
    log = simulate_drive(mixed_program(30.0, seed=2, robot=robot), robot, seed=3)
    bag = write_drive_bag(log, tmp / "drive", storage="mcap", odom=True)
    db, save = tmp / "h.sqlite", tmp / "selfcal.json"
    record_analysis("r1", a, db=db, when="2026-01-10")
    geo = ["--joints", "left_wheel_joint,right_wheel_joint", "--wheel-diameter-mm", "150", "--wheelbase-mm", "340"]
    args = ["selfcal", str(bag), *geo, "--save", str(save), "--robot", "r1", "--record", "--db", str(db)]
    assert main(["-q", *args]) == 0
    assert main(["-q", "report", str(save), "--out", str(tmp / "selfcal.html")]) == 0
    assert main(["-q", "report", "--robot", "r1", "--db", str(db), "--out", str(tmp / "history.html")]) == 0
    # a calibration loop (umbmark calibrate --json) and a gyro result (replay --imu-topic --save)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["-q", "calibrate", "--seed", "1", "--json"]) == 0
    (tmp / "calibrate.json").write_text(out.getvalue())
    assert main(["-q", "report", str(tmp / "calibrate.json"), "--out", str(tmp / "calibrate.html")]) == 0
    spins = [Command(2.0)]
    for sign in (1, -1, 1, -1):
        spins += [Command(2 * math.pi / 0.8, 0.0, sign * 0.8), Command(1.5)]
    log = simulate_drive(Program(tuple(spins)), robot, seed=4)
    t, w = simulate_gyro(log, Gyro(100.0, 1.0, 0.01, 0.005), seed=5)
    gbag = write_drive_bag(log, tmp / "gyro", gyro=(t, w), odom=False)
    gyro = ["replay", str(gbag), "--imu-topic", "/imu", *geo, "--save", str(tmp / "gyro.json")]
    assert main(["-q", *gyro]) == 0
    assert main(["-q", "report", str(tmp / "gyro.json"), "--out", str(tmp / "gyro.html")]) == 0
    # another kind of robot's self-calibration (a mecanum robot's)
    from kinematic_bags import write_short_drive

    (tmp / "mecanum").mkdir()
    drive = write_short_drive(tmp / "mecanum", "mecanum")
    kind = ["selfcal", str(drive["bag"]), "--kinematics", "mecanum", *drive["joints"], *drive["sizes"]]
    assert main(["-q", *kind, "--save", str(tmp / "kind.json")]) == 0
    assert main(["-q", "report", str(tmp / "kind.json"), "--out", str(tmp / "kind_selfcal.html")]) == 0
    return tmp


@needs_browser
@pytest.mark.parametrize(
    "name, images",
    [("analysis", 1), ("selfcal", 3), ("calibrate", 1), ("gyro", 1), ("history", 1), ("kind_selfcal", 3)],
)
def test_reports_render(reports, tmp_path, name, images):
    page = reports / f"{name}.html"
    check_page(page.read_text())
    r = render(page, tmp_path)
    _keep(r)
    assert_rendered(r, min_images=images)
    assert r["text"] > 500


# -- the documentation site ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    given = os.environ.get("UMBMARK_DOCS_SITE")
    if given:
        assert (Path(given) / "index.html").is_file(), f"UMBMARK_DOCS_SITE={given} holds no built site"
        src = Path(given)
    else:
        pytest.importorskip("mkdocs")
        src = tmp_path_factory.mktemp("site") / "site"
        env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
        cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(src)]
        p = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, env=env, timeout=300)
        assert p.returncode == 0, p.stderr[-2000:]
    # a copy: the checks write their probes beside the pages
    dst = tmp_path_factory.mktemp("served") / "site"
    shutil.copytree(src, dst)
    return dst


@pytest.fixture(scope="module")
def served(site):
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(site)))
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{srv.server_address[1]}/"
    srv.shutdown()
    srv.server_close()


# the home page, the longest guide, the page of the reports and an API page (the rest share their
# theme and scripts; every page's links are checked below without a browser)
DOC_PAGES = ["index.html", "selfcal/index.html", "history/index.html"]
API_PAGES = ["api/viz/index.html"]


@needs_browser
@pytest.mark.parametrize("rel", DOC_PAGES + API_PAGES)
def test_docs_pages_render(site, served, tmp_path, rel):
    r = render(site / rel, tmp_path, url=served + rel)
    _keep(r)
    assert_rendered(r, min_images=0)
    assert r["title"].startswith("umbmark") or r["title"].endswith("- umbmark")
    assert r["text"] > 1000


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for k in ("href", "src"):
            if a.get(k) and tag in ("a", "link", "script", "img"):
                self.refs.append(a[k])


def _parse(path: Path) -> _Links:
    p = _Links()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def test_docs_links_resolve(site):
    """Every link of every page of the site to a page, file or anchor of the site exists."""
    pages = {p: _parse(p) for p in site.rglob("*.html") if p.name != "404.html"}
    assert len(pages) > 15
    broken = []
    for page, links in pages.items():
        for ref in links.refs:
            u = urlsplit(ref)
            if u.scheme or u.netloc or ref.startswith(("mailto:", "data:", "javascript:")):
                continue
            target = (page.parent / unquote(u.path)).resolve() if u.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                broken.append(f"{page.relative_to(site)}: {ref}")
                continue
            if u.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(u.fragment) not in ids:
                    broken.append(f"{page.relative_to(site)}: {ref} (no such anchor)")
    assert not broken, "\n".join(sorted(set(broken)))


class _Text(HTMLParser):
    def __init__(self):
        super().__init__()
        self.parts = []

    def handle_data(self, data):
        self.parts.append(data)


def test_api_pages_show_no_sphinx_roles(site):
    """The docstrings' :mod:, :func:, :class: ... references are links in the built pages, never
    the raw role."""
    api = sorted((site / "api").rglob("*.html"))
    assert len(api) >= 8
    raw = []
    for page in api:
        t = _Text()
        t.feed(page.read_text(encoding="utf-8"))
        text = "".join(t.parts)
        raw += [f"{page.relative_to(site)}: {m}" for m in re.findall(r":(?:mod|func|class|meth|attr|data|obj):", text)]
    assert not raw, "\n".join(raw[:20])
    # and they became links to the objects' entries
    viz = (site / "api" / "viz" / "index.html").read_text(encoding="utf-8")
    assert re.search(r'<a [^>]*href="[^"]*#umbmark\.viz\.report\.figure_data_uri"', viz)


def test_search_index_is_part_of_the_site(site):
    d = json.loads((site / "search" / "search_index.json").read_text(encoding="utf-8"))
    assert any("selfcal" in doc["location"] for doc in d["docs"])
