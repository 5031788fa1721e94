"""`umbmark reproduce`: the pinned JSON, determinism, the HTML report, bad input."""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser

import matplotlib.image as mpimg
import numpy as np
import pytest

from umbmark.cli import main
from umbmark.viz import plots as plot


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_json_pinned_interface(capsys):
    code, out, err = run(capsys, "reproduce", "--json", "--seeds", "3", "--no-pitfall")
    assert code == 0, err
    d = json.loads(out)
    exps = d["experiments"]
    assert [e["id"] for e in exps] == list(range(1, 9))
    for e in exps:
        for k in ("emax_before_mm", "emax_after_mm", "improvement"):
            assert isinstance(e[k], float) and e[k] > 0
        assert e["second_pass"] is None or e["second_pass"]["emax_after_mm"] > 0
        assert 100 < e["emax_before_mm"] < 1000  # hundreds of mm, like the paper's
    dist = d["distribution"]
    for k in (
        "seeds",
        "improvement_median",
        "improvement_p10",
        "improvement_p90",
        "emax_before_median_mm",
        "emax_after_median_mm",
        "second_pass_fraction",
    ):
        assert k in dist
    assert dist["seeds"] == 3
    assert d["command"] == "umbmark reproduce --seed 1 --seeds 3 --no-pitfall"
    assert "pitfall" not in d


def test_same_seeds_give_identical_json_bytes(capsys):
    args = ("reproduce", "--json", "--seeds", "2", "--seed", "11")
    _, a, _ = run(capsys, *args)
    _, b, _ = run(capsys, *args)
    assert a == b
    _, c, _ = run(capsys, "reproduce", "--json", "--seeds", "2", "--seed", "12")
    assert c != a
    assert json.loads(a)["pitfall"]["uni_directionally_tuned"]["ccw_r_cg_mm"] > 100


def test_human_output_lists_the_table_and_the_rerun_command(capsys):
    code, out, _ = run(capsys, "reproduce", "--seeds", "2", "--no-pitfall")
    assert code == 0
    assert "Table I in simulation, seed 1" in out
    assert "(317)" in out and "(423)" in out  # the paper's numbers beside ours
    assert "re-run: umbmark reproduce --seed 1 --seeds 2 --no-pitfall" in out


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.imgs, self.rows, self.h2 = [], 0, []
        self._in_h2 = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.imgs.append(a)
        elif tag == "tr":
            self.rows += 1
        elif tag == "h2":
            self._in_h2 = True
            self.h2.append("")

    def handle_endtag(self, tag):
        if tag == "h2":
            self._in_h2 = False

    def handle_data(self, data):
        if self._in_h2:
            self.h2[-1] += data


def test_report_is_self_contained_and_its_images_decode(tmp_path, capsys):
    out_dir = tmp_path / "rep"
    code, out, err = run(capsys, "reproduce", "--seeds", "2", "--report", str(out_dir), "--exaggerate", "5", "--json")
    assert code == 0, err
    assert json.loads(out)["report"] == str(out_dir / "index.html")
    page = _Page()
    page.feed((out_dir / "index.html").read_text(encoding="utf-8"))
    assert len(page.imgs) == 4
    for img in page.imgs:
        src = img["src"]
        assert src.startswith("data:image/png;base64,")
        png = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        assert img.get("alt")
    assert page.rows >= 1 + 8 + 1 + 5  # Table I (header + 8) and the distribution table
    assert any("pitfall" in h for h in page.h2)
    for name in ("scatter", "trajectories", "pitfall", "distribution"):
        arr = mpimg.imread(out_dir / f"{name}.png")
        assert arr.ndim == 3 and arr.shape[0] > 200 and arr.shape[1] > 200
        assert np.ptp(arr) > 0  # not a blank image
        svg = (out_dir / f"{name}.svg").read_text(encoding="utf-8")
        assert "<svg" in svg
    assert not list(out_dir.glob(".*"))  # no temporary files left behind
    # the same study gives the same figure files, byte for byte
    other = tmp_path / "rep2"
    assert run(capsys, "reproduce", "--seeds", "2", "--report", str(other), "--exaggerate", "5", "--json")[0] == 0
    for f in sorted(out_dir.glob("*.*g")):
        assert (other / f.name).read_bytes() == f.read_bytes(), f.name


@pytest.mark.parametrize(
    "args, what",
    [
        (["--seeds", "0"], "--seeds"),
        (["--tape-thickness-mm", "-1"], "--tape-thickness-mm"),
        (["--sample-period-ms", "0"], "--sample-period-ms"),
        (["--variation", "nan"], "variation"),
        (["--exaggerate", "0"], "--exaggerate"),
        (["--runs", "1"], "--runs"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, args, what):
    code, out, err = run(capsys, "reproduce", "--no-pitfall", *args)
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert what in err


def test_report_into_a_file_is_refused(tmp_path, capsys):
    f = tmp_path / "afile"
    f.write_text("x")
    code, _, err = run(capsys, "reproduce", "--seeds", "1", "--no-pitfall", "--report", str(f))
    assert code == 2 and err.count("\n") == 1


def test_exaggerated_trajectory_scales_the_deviation_only():
    t = {
        "true_x": np.array([0.0, 1.0, 2.0]),
        "true_y": np.array([0.0, 0.1, 0.3]),
        "odo_x": np.array([0.0, 1.0, 2.0]),
        "odo_y": np.array([0.0, 0.0, 0.0]),
        "label": "cw",
    }
    fig = plot.exaggerated_trajectory_figure([t], exaggerate=10, side_m=2.0)
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    true_line = lines["cw: true path (deviation x10)"]
    np.testing.assert_allclose(true_line.get_ydata(), [0.0, 1000.0, 3000.0])
    np.testing.assert_allclose(lines["cw: odometry"].get_ydata(), [0, 0, 0])
    assert ax.get_aspect() == 1.0 and "[mm]" in ax.get_xlabel() and "[mm]" in ax.get_ylabel()
    assert ax.get_legend() is not None
    plot.close_figure(fig)
    with pytest.raises(ValueError):
        plot.exaggerated_trajectory_figure([t], exaggerate=0)
