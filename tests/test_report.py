"""HTML reports: well-formed, self-contained, images that decode (rendered in a browser: test_browser.py)."""

import json
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest
from pages import PNG, check_page

from umbmark.cli import main
from umbmark.correct.analysis import analyze
from umbmark.history import History
from umbmark.io.runs_csv import write_runs_csv
from umbmark.model.geometry import FIG11_ERRORS, ErrorParams
from umbmark.model.simulate import simulate_umbmark
from umbmark.viz.report import analysis_report, bootstrap_intervals, cg_intervals, history_report


@pytest.fixture(scope="module")
def analysis():
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=1)
    return analyze(runs, 4.0, 0.34)


def test_analysis_report_is_valid_and_self_contained(analysis):
    after = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=2, calibration=analysis.correction.calibration)
    boot = bootstrap_intervals(analysis.runs, 4.0, 0.34, n_boot=200, seed=0)
    traj = [
        {
            "true_x": [0, 1, 1],
            "true_y": [0, 0, 1],
            "odo_x": [0, 1.01, 1.02],
            "odo_y": [0, 0.01, 1.0],
            "label": "run 1 <cw>",
        }
    ]
    page = analysis_report(
        analysis,
        title="Test <report> & co",
        after_runs=after,
        trajectories=traj,
        exported={"params.json": '{"c_left": 0.99}'},
        boot=boot,
        robot="r&1",
    )
    c = check_page(page)
    assert len(c.images) == 2  # scatter and trajectories
    text = "".join(c.text)
    assert "Test <report> & co" in text and "r&1" in text  # escaped in the source, restored by the parser
    assert f"{analysis.result.emax_syst * 1e3:.1f} mm" in text
    assert f"{analysis.correction.calibration.c_left:.6f}" in text
    assert '{"c_left": 0.99}' in text


def test_intervals(analysis):
    runs = analysis.runs
    ci = cg_intervals(runs)
    from scipy import stats

    cw = runs.direction_rows("cw")
    half = stats.t.ppf(0.975, 4) * np.std(cw.eps_x, ddof=1) / np.sqrt(5) * 1e3
    assert ci["cw"]["x"] == pytest.approx((cw.eps_x.mean() * 1e3 - half, cw.eps_x.mean() * 1e3 + half))
    b = bootstrap_intervals(runs, 4.0, 0.34, n_boot=300, seed=1)
    assert b["failed"] == 0
    for key, est in (
        ("Ed", analysis.correction.ed),
        ("Eb", analysis.correction.eb),
        ("wheelbase_mm", analysis.correction.calibration.wheelbase_m * 1e3),
    ):
        lo, hi = b[key]
        assert lo < est < hi, key
    # the same seed gives the same intervals
    assert bootstrap_intervals(runs, 4.0, 0.34, n_boot=300, seed=1) == b
    # the wheelbase interval of a noise-free test is a point
    exact = analyze(simulate_umbmark(FIG11_ERRORS, n_runs=3, seed=0), 4.0, 0.34)
    lo, hi = bootstrap_intervals(exact.runs, 4.0, 0.34, n_boot=50)["wheelbase_mm"]
    assert hi - lo < 1e-9


def test_history_report(tmp_path):
    db = tmp_path / "h.sqlite"
    from umbmark.history import record_analysis

    for k, when in enumerate(["2026-01-10", "2026-03-10", "2026-06-10"]):
        runs = simulate_umbmark(ErrorParams(1.001 + k * 1e-3, 0.99), n_runs=5, noise="paper", seed=k)
        record_analysis("bot", analyze(runs, 4.0, 0.34), db=db, when=when)
    with History(db) as h:
        recs = h.records("bot")
    page = history_report(recs, db_path=str(db))
    c = check_page(page)
    assert len(c.images) == 2  # history plot and the latest scatter
    text = "".join(c.text)
    for r in recs:
        assert f"#{r.id}" in text and r.created_utc[:10] in text


def test_report_cli(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("UMBMARK_DB", str(tmp_path / "h.sqlite"))
    runs = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=1)
    a = analyze(runs, 4.0, 0.34)
    after = simulate_umbmark(FIG11_ERRORS, n_runs=5, noise="paper", seed=2, calibration=a.correction.calibration)
    write_runs_csv(runs, tmp_path / "before.csv")
    write_runs_csv(after, tmp_path / "after.csv")
    (tmp_path / "p.json").write_text('{"c_left": 1}')
    out = tmp_path / "r.html"
    assert (
        main(
            [
                "report",
                str(tmp_path / "before.csv"),
                "--wheelbase-mm",
                "340",
                "--side-mm",
                "4000",
                "--after",
                str(tmp_path / "after.csv"),
                "--attach",
                str(tmp_path / "p.json"),
                "--bootstrap",
                "100",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    j = json.loads(capsys.readouterr().out)
    assert j["bootstrap"]["n_boot"] == 100 and j["emax_syst_mm"] == pytest.approx(a.result.emax_syst * 1e3)
    text = "".join(check_page(out.read_text()).text)
    assert "improvement" in text and "p.json" in text

    assert (
        main(
            [
                "analyze",
                str(tmp_path / "before.csv"),
                "--wheelbase-mm",
                "340",
                "--side-mm",
                "4000",
                "--robot",
                "bot",
                "--record",
                "--json",
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert main(["report", "--robot", "bot", "--out", str(tmp_path / "h.html")]) == 0
    check_page((tmp_path / "h.html").read_text())
    assert main(["report", "--id", "1", "--out", str(tmp_path / "one.html"), "--bootstrap", "0"]) == 0
    one = "".join(check_page((tmp_path / "one.html").read_text()).text)
    assert f"{a.result.emax_syst * 1e3:.1f} mm" in one
    capsys.readouterr()
    # errors: one line, exit 2, no file written
    assert main(["report", "--out", str(tmp_path / "x.html")]) == 2
    assert main(["report", str(tmp_path / "before.csv"), "--out", str(tmp_path / "x.html")]) == 2
    assert "--wheelbase-mm and --side-mm are required" in capsys.readouterr().err
    assert main(["report", "--robot", "ghost", "--out", str(tmp_path / "x.html")]) == 2
    assert not (tmp_path / "x.html").exists()


BACKEND_PROBE = """
import sys, matplotlib
from matplotlib import rcParams
{choose}
before = dict.__getitem__(rcParams, "backend")
import umbmark.viz.plots as plots, umbmark.viz.history_plot, umbmark.viz.report
from umbmark.model.geometry import ErrorParams
from umbmark.model.simulate import simulate_umbmark
runs = simulate_umbmark(ErrorParams(1.002, 0.99), n_runs=2)
plots.save_figure(plots.scatter_figure(runs, runs), sys.argv[1])
after = dict.__getitem__(rcParams, "backend")
print(repr(before) + "|" + repr(after) + "|" + str("matplotlib.pyplot" in sys.modules))
"""


@pytest.mark.parametrize("choose", ["", "matplotlib.use('svg')"], ids=["nothing chosen", "svg chosen"])
def test_figures_leave_the_matplotlib_backend_alone(tmp_path, choose):
    """Importing the figure modules, making and saving a figure: matplotlib's backend is what it was
    (nothing chosen stays nothing chosen, so a notebook keeps its own), and pyplot is not loaded."""
    import os
    import sys

    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    out = tmp_path / "scatter.png"
    p = subprocess.run(
        [sys.executable, "-c", BACKEND_PROBE.format(choose=choose), str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=True,
    )
    before, after, pyplot = p.stdout.strip().split("|")
    assert before == after and pyplot == "False"
    assert out.read_bytes()[:8] == PNG


# -- the history page: a table that fits 1280 px, a time axis in dates --------------------------------


def _seconds_apart_history(tmp_path):
    from umbmark.history import record_analysis

    db = tmp_path / "h.sqlite"
    for k, when in enumerate(["2026-01-10T12:00:00", "2026-01-10T12:00:01.500", "2026-01-10T12:00:03"]):
        runs = simulate_umbmark(ErrorParams(1.001 + k * 1e-3, 0.99), n_runs=5, noise="paper", seed=k)
        record_analysis(
            "a-robot-with-a-long-name", analyze(runs, 4.0, 0.34), db=db, when=when, source="x" * 60 + ".csv"
        )
    with History(db) as h:
        return h.records("a-robot-with-a-long-name")


def test_history_time_axis_labels_dates_also_for_records_seconds_apart(tmp_path):
    from umbmark.viz.history_plot import history_figure

    for recs in (_seconds_apart_history(tmp_path), None):
        if recs is None:  # and months apart
            from umbmark.history import record_analysis

            db = tmp_path / "m.sqlite"
            for k, when in enumerate(["2026-01-10", "2026-03-10", "2026-06-10"]):
                runs = simulate_umbmark(ErrorParams(1.001, 0.99), n_runs=5, noise="paper", seed=k)
                record_analysis("bot", analyze(runs, 4.0, 0.34), db=db, when=when)
            with History(db) as h:
                recs = h.records("bot")
        fig = history_figure(recs)
        fig.canvas.draw()
        ax = fig.axes[-1]
        labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
        assert len(labels) >= 2 and len(set(labels)) == len(labels)
        assert all(lab.startswith("2026-") for lab in labels), labels  # dates, not "12.5 ... 14.0"
        assert ax.xaxis.get_offset_text().get_text() == ""
        lo, hi = ax.get_xlim()
        import matplotlib.dates as mdates

        times = [r.time for r in recs]
        assert mdates.num2date(lo) < min(times) and max(times) < mdates.num2date(hi)


class _Table(HTMLParser):
    """The cells of the records table, with the classes of the table, the body and each cell."""

    def __init__(self):
        super().__init__()
        self.body_cls, self.in_records, self.rows, self.cell = None, False, [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.body_cls = a.get("class")
        if tag == "table" and a.get("class") == "records":
            self.in_records = True
        if self.in_records and tag == "tr":
            self.rows.append([])
        if self.in_records and tag in ("td", "th"):
            self.cell = [tag, a.get("class"), ""]

    def handle_endtag(self, tag):
        if tag == "table":
            self.in_records = False
        if self.in_records and tag in ("td", "th") and self.cell is not None:
            self.rows[-1].append(tuple(self.cell))
            self.cell = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell[2] += data


def _css_rules(page: str) -> dict[str, str]:
    import re

    css = re.search(r"<style>(.*?)</style>", page, re.S).group(1)
    return {sel.strip(): body for sel, body in re.findall(r"([^{}]+)\{([^}]*)\}", css)}


def test_history_table_fits_a_1280_px_window(tmp_path):
    """No browser here: the CSS rules and the cells' widths are checked. Digits and letters at
    most 0.62 em wide, the cell padding of the style sheet; cells that may wrap count with
    their longest word, the input column with at most its max-width."""
    recs = _seconds_apart_history(tmp_path)
    page = history_report(recs)
    rules = _css_rules(page)
    t = _Table()
    t.feed(page)
    assert t.body_cls == "wide" and "max-width:75em" in rules["body.wide"]
    assert "font-size:.8em" in rules["table.records"]
    assert "white-space:nowrap" in rules["table.records td"]
    assert (
        "overflow-wrap:anywhere" in rules["table.records td.src"] and "max-width:14em" in rules["table.records td.src"]
    )
    base_px, font = 16.0, 0.8 * 16.0
    content_px = min(1280 - 2 * base_px - 17, 75 * base_px - 2 * base_px)  # margins, a scroll bar
    ncol = len(t.rows[0])
    widths = [0.0] * ncol
    for row in t.rows:
        assert len(row) == ncol
        for j, (tag, cls, text) in enumerate(row):
            if cls == "src":
                w = min(len(text) * 0.62 * font, 14 * font)
            elif tag == "th":
                w = max(len(word) for word in text.split()) * 0.62 * font
            else:
                w = len(text) * 0.62 * font
            widths[j] = max(widths[j], w + 2 * 0.6 * font + 1)
    assert sum(widths) < content_px, (sum(widths), widths)
    text = "".join(c[2] for row in t.rows for c in row)
    for r in recs:  # seconds apart: the times tell them apart
        assert r.created_utc[:19].replace("T", " ") in text


# -- the report of a replay result ------------------------------------------------------------------


@pytest.fixture(scope="module")
def replay_bag(tmp_path_factory):
    """A simulated ROS 2 bag of 2 cw and 2 ccw 2 m squares (wheels and ground truth)."""
    pytest.importorskip("rosbags")
    import dataclasses
    import math

    from umbmark.io.rosbag_write import write_drive_bag
    from umbmark.model.drive import EXAMPLE_ROBOT, Command, simulate_drive
    from umbmark.model.sensors import Lidar

    robot = dataclasses.replace(
        EXAMPLE_ROBOT, errors=ErrorParams(ed=1.004, eb=1.02), lidar=Lidar(n_beams=4, range_noise_m=0.0)
    )

    def square(sign: int) -> list:
        legs = []
        for _ in range(4):
            legs += [Command(2.0 / 0.4, 0.4), Command(0.3), Command(math.pi / 2 / 0.8, 0.0, sign * 0.8), Command(0.3)]
        return legs + [Command(2.5)]

    program = [Command(2.5)] + square(-1) + square(1) + square(-1) + square(1)
    log = simulate_drive(program, robot, start_pose=(4.0, 4.0, 0.0), scan_rate_hz=1.0, seed=1)
    bag = write_drive_bag(log, tmp_path_factory.mktemp("bags") / "squares", truth=True, odom=False)
    return bag, robot.nominal_wheels


def _replay_args(bag, nominal, method, save):
    from umbmark.io.rosbag_write import JOINT_NAMES

    return [
        "-q",
        "replay",
        str(bag),
        "--joints",
        ",".join(JOINT_NAMES),
        "--gt-topic",
        "/ground_truth",
        "--wheel-diameter-mm",
        f"{nominal.diameter_left_m * 1e3:g}",
        "--wheelbase-mm",
        f"{nominal.wheelbase_m * 1e3:g}",
        "--side-mm",
        "2000",
        "--split-stops",
        "--method",
        method,
        "--no-heldout",
        "--save",
        str(save),
    ]


@pytest.mark.parametrize("method", ["bf", "exact"])
def test_report_of_a_replay_result(replay_bag, tmp_path, capsys, method):
    """``report RESULT.json`` of ``replay --save``: the replay's runs before and after its
    calibration, the calibration it found, the bootstrap by default (bf and exact, a few runs)."""
    bag, nominal = replay_bag
    save = tmp_path / "replay.json"
    assert main(_replay_args(bag, nominal, method, save)) == 0
    capsys.readouterr()
    rep = json.loads(save.read_text())
    out = tmp_path / "r.html"
    assert main(["report", str(save), "--out", str(out), "--json"]) == 0
    j = json.loads(capsys.readouterr().out)
    assert j["emax_syst_mm"] == pytest.approx(rep["before"]["emax_syst_mm"], rel=1e-9)
    boot = j["bootstrap"]
    assert boot is not None and boot["n_boot"] >= 200 and boot["failed"] == 0
    assert boot["Ed"][0] <= rep["Ed"] <= boot["Ed"][1]
    page = out.read_text()
    text = "".join(check_page(page).text)
    assert f"replay of {rep['dataset']}" in text and f"Correction (method {method})" in text
    assert f"c_left = {rep['c_left']:.6f}" in text and f"wheelbase = {rep['wheelbase_corrected_mm']:.2f} mm" in text
    after = rep["after"]["emax_syst_mm"]
    assert f"after: {after:.1f} mm" in text
    if method == "exact":
        assert "odometry's end poses" in text  # the bootstrap's caveat is said


def test_report_of_a_replay_result_refuses_what_it_cannot_use(replay_bag, tmp_path, capsys):
    bag, nominal = replay_bag
    save = tmp_path / "replay.json"
    assert main(_replay_args(bag, nominal, "bf", save)) == 0
    out = tmp_path / "x.html"
    capsys.readouterr()
    for extra, said in (
        (["--side-mm", "2000"], "drop --side-mm"),
        (["--method", "exact"], "calibrated with bf; drop --method exact"),
    ):
        assert main(["report", str(save), "--out", str(out), *extra]) == 2
        err = capsys.readouterr().err
        assert said in err and len(err.strip().splitlines()) == 1
    d = json.loads(save.read_text())
    for name, broken, said in (
        ("path.json", {**d, "kind": "path"}, "a replay along a general path"),
        ("other.json", {"Ed": 1.0}, "not a result the report can show"),
        (
            "analysis.json",
            {"cw": {}, "ccw": {}, "emax_syst_mm": 1.0, "file": "runs.csv"},
            "runs file it was made from (runs.csv)",
        ),
        ("norun.json", {**d, "before": {"runs": [{"run": "a"}]}}, "have no return errors"),
    ):
        (tmp_path / name).write_text(json.dumps(broken))
        assert main(["report", str(tmp_path / name), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert said in err and name in err and len(err.strip().splitlines()) == 1
    (tmp_path / "cut.json").write_text(save.read_text()[:100])
    assert main(["report", str(tmp_path / "cut.json"), "--out", str(out)]) == 2
    assert "not a replay result" in capsys.readouterr().err
    assert not out.exists()


def test_default_bootstrap_follows_the_measured_cost_of_exact():
    from umbmark.viz.report import BOOTSTRAP_BUDGET_S, EXACT_RESAMPLE_COST_S, default_bootstrap

    assert default_bootstrap("bf", 10**6) == (1000, None)
    assert default_bootstrap("lsq", 10) == (0, None)
    a, b = EXACT_RESAMPLE_COST_S
    for n in (10, 100, 1000, 10**4, 10**5):
        n_boot, note = default_bootstrap("exact", n)
        assert n_boot * (a + b * n) <= BOOTSTRAP_BUDGET_S
        assert (note is None) == (n_boot == 1000)
        if n_boot == 0:
            assert "skipped" in note and f"{n} runs" in note
        elif n_boot < 1000:
            assert (n_boot + 100) * (a + b * n) > BOOTSTRAP_BUDGET_S and f"{n_boot} resamples" in note
    assert default_bootstrap("exact", 10**5)[0] == 0


def test_report_of_a_recorded_replay(replay_bag, tmp_path, capsys):
    """``report --id N`` of a replay recorded in the history: the runs it built, as from its JSON."""
    bag, nominal = replay_bag
    save, db = tmp_path / "replay.json", tmp_path / "h.sqlite"
    args = _replay_args(bag, nominal, "exact", save) + ["--robot", "bot", "--record", "--db", str(db)]
    assert main(args) == 0
    rep = json.loads(save.read_text())
    capsys.readouterr()
    out = tmp_path / "id.html"
    assert main(["report", "--id", "1", "--db", str(db), "--out", str(out), "--json"]) == 0
    j = json.loads(capsys.readouterr().out)
    assert j["emax_syst_mm"] == pytest.approx(rep["before"]["emax_syst_mm"], rel=1e-9)
    text = "".join(check_page(out.read_text()).text)
    assert "(replay)" in text and f"c_left = {rep['c_left']:.6f}" in text
    assert f"after: {rep['after']['emax_syst_mm']:.1f} mm" in text
