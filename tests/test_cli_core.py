import json
import math
import subprocess
import sys

import pytest

from umbmark.cli import main

PINNED = [
    "emax_syst_mm",
    "alpha_deg",
    "beta_deg",
    "radius_mm",
    "Ed",
    "Eb",
    "c_left",
    "c_right",
    "wheelbase_corrected_mm",
    "second_pass_recommended",
]
PINNED_DIR = ["n", "x_cg_mm", "y_cg_mm", "r_cg_mm", "std_mm", "sem_mm"]


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def analyze_json(capsys, path, *extra):
    code, out, err = run(
        capsys, "analyze", str(path), "--wheelbase-mm", "340", "--side-mm", "4000", "--method", "bf", "--json", *extra
    )
    assert code == 0, err
    return json.loads(out)


def test_simulate_then_analyze_recovers_the_robot(tmp_path, capsys):
    f = tmp_path / "runs.csv"
    code, _, err = run(
        capsys,
        "simulate",
        "--ed",
        "1.004",
        "--eb",
        "0.985",
        "--runs",
        "3",
        "--seed",
        "2",
        "--noise",
        "none",
        "--out",
        str(f),
    )
    assert code == 0, err
    d = analyze_json(capsys, f)
    for k in PINNED:
        assert k in d
    for side in ("cw", "ccw"):
        for k in PINNED_DIR:
            assert k in d[side]
        assert d[side]["n"] == 3
    assert isinstance(d["second_pass_recommended"], bool)
    assert abs(d["Ed"] - 1.004) < 3e-4 and abs(d["Eb"] - 0.985) < 3e-3
    assert d["wheelbase_corrected_mm"] == pytest.approx(340 * d["Eb"])


def test_other_geometry_flags(tmp_path, capsys):
    f = tmp_path / "runs.csv"
    assert (
        run(
            capsys,
            "simulate",
            "--ed",
            "0.998",
            "--eb",
            "1.01",
            "--runs",
            "2",
            "--wheelbase-mm",
            "200",
            "--side-mm",
            "1500",
            "--out",
            str(f),
        )[0]
        == 0
    )
    code, out, err = run(capsys, "analyze", str(f), "--wheelbase-mm", "200", "--side-mm", "1500", "--json")
    d = json.loads(out)
    assert abs(d["Ed"] - 0.998) < 3e-4 and abs(d["Eb"] - 1.01) < 3e-3


def test_analyze_matches_the_formulas_on_any_file(tmp_path, capsys):
    f = tmp_path / "hand.csv"
    f.write_text("direction,x_abs,y_abs,x_odo,y_odo\ncw,60,70,1,2\ncw,70,60,-1,0\nccw,230,-200,3,3\nccw,220,-210,0,0\n")
    d = analyze_json(capsys, f)
    xcw, ycw = (59 + 71) / 2, (68 + 60) / 2
    xccw, yccw = (227 + 220) / 2, (-203 - 210) / 2
    L, b = 4000.0, 340.0
    beta = ((xcw - xccw) / (-4 * L) + (ycw + yccw) / (-4 * L)) / 2
    alpha = ((xcw + xccw) / (-4 * L) + (ycw - yccw) / (-4 * L)) / 2
    R = (L / 2) / math.sin(beta / 2)
    ed = (R + b / 2) / (R - b / 2)
    eb = 90 / (90 - math.degrees(alpha))
    want = {
        "alpha_deg": math.degrees(alpha),
        "beta_deg": math.degrees(beta),
        "radius_mm": R,
        "Ed": ed,
        "Eb": eb,
        "c_left": 2 / (ed + 1),
        "c_right": 2 / (1 / ed + 1),
        "wheelbase_corrected_mm": eb * b,
        "emax_syst_mm": math.hypot(xccw, yccw),
    }
    for k, v in want.items():
        assert d[k] == pytest.approx(v, rel=1e-9), k
    assert d["ccw"]["x_cg_mm"] == pytest.approx(xccw, rel=1e-12)


def test_analyze_second_pass_flags(tmp_path, capsys):
    f = tmp_path / "r.csv"
    f.write_text("direction,x_abs,y_abs,x_odo,y_odo\ncw,10,10,0,0\nccw,-10,12,0,0\n")
    d1 = analyze_json(capsys, f)
    d2 = analyze_json(capsys, f, "--c-left", "0.999", "--c-right", "1.001")
    assert d2["Ed"] == pytest.approx(d1["Ed"] * 1.001 / 0.999, rel=1e-12)


def test_human_output_is_a_table(tmp_path, capsys):
    f = tmp_path / "r.csv"
    run(capsys, "simulate", "--ed", "1.002", "--out", str(f), "--runs", "2")
    code, out, _ = run(
        capsys, "analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(tmp_path / "s.png")
    )
    assert code == 0
    assert "E_max,syst" in out and "c_left" in out and "[mm]" in out
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


BAD = [
    ("missing.csv", None, "file not found"),
    ("nohead.csv", "cw,1,2,3,4\nccw,1,2,3,4\n", "no header"),
    ("dir.csv", "direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\nup,1,2,3,4\n", ":3: unknown direction"),
    ("num.csv", "direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\nccw,1,x,3,4\n", ":3: column y_abs"),
    ("nan.csv", "direction,x_abs,y_abs,x_odo,y_odo\ncw,NaN,2,3,4\nccw,1,2,3,4\n", ":2: column x_abs"),
    ("oneway.csv", "direction,x_abs,y_abs,x_odo,y_odo\ncw,1,2,3,4\ncw,1,2,3,4\n", "no ccw runs"),
    # finite but absurd: a position of 1e308 mm would overflow into a calibration of E_b 1e-303
    (
        "huge.csv",
        "direction,x_abs,y_abs,x_odo,y_odo\ncw,1e308,2,3,4\nccw,1,2,3,4\n",
        ":2: column x_abs: 1e308 mm is more",
    ),
    (
        "heading.csv",
        "direction,x_abs,y_abs,x_odo,y_odo,theta_abs,theta_odo\ncw,1,2,3,4,1e300,0\nccw,1,2,3,4,0,0\n",
        ":2: column theta_abs: 1e300 is not a heading",
    ),
]


@pytest.mark.parametrize("name, content, match", BAD)
def test_bad_files_one_line_exit_2(tmp_path, capsys, name, content, match):
    f = tmp_path / name
    if content is not None:
        f.write_text(content)
    code, out, err = run(capsys, "analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--json")
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and match in err and name in err


@pytest.mark.parametrize(
    "flags, match",
    [
        (["--wheelbase-mm", "0", "--side-mm", "4000"], "--wheelbase-mm must be a positive"),
        (["--wheelbase-mm", "-340", "--side-mm", "4000"], "--wheelbase-mm must be a positive"),
        (["--wheelbase-mm", "340", "--side-mm", "0"], "--side-mm must be a positive"),
        (["--wheelbase-mm", "nan", "--side-mm", "4000"], "--wheelbase-mm must be a positive"),
        (["--wheelbase-mm", "340", "--side-mm", "4000", "--method", "magic"], "Invalid value for '--method'"),
        (["--wheelbase-mm", "abc", "--side-mm", "4000"], "Invalid value for '--wheelbase-mm'"),
        (["--side-mm", "4000"], "Missing option '--wheelbase-mm'"),
        (["--wheelbase-mm", "6000", "--side-mm", "100"], "not longer than the wheelbase"),
    ],
)
def test_bad_flags_one_line_exit_2(tmp_path, capsys, flags, match):
    f = tmp_path / "r.csv"
    f.write_text("direction,x_abs,y_abs,x_odo,y_odo\ncw,-60,-60,0,0\nccw,60,-60,0,0\n")
    code, out, err = run(capsys, "analyze", str(f), *flags)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and match in err


def test_simulate_bad_values(tmp_path, capsys):
    for flags, match in (
        (["--ed", "-1"], "--ed must be a number from 0.5 to 2"),
        (["--runs", "0"], "--runs"),
        (["--es", "1e308"], "--es must be a number from 0.5 to 2"),
        (["--eb", "1e-9"], "--eb must be a number from 0.05 to 20"),
        (["--noise", "loud"], "--noise"),
    ):
        code, _, err = run(capsys, "simulate", *flags, "--out", str(tmp_path / "x.csv"))
        assert code == 2 and err.count("\n") == 1 and match in err
    # inputs that would need more samples than memory holds (a MemoryError, or the process
    # killed) are refused before anything is allocated
    for flags, match in (
        (["--side-mm", "1e12"], "more than 1 km: check the unit"),
        (["--speed", "1e-12"], "samples (more than 5,000,000)"),
        (["--sample-period-ms", "1e-9"], "samples (more than 5,000,000)"),
        (["--wheelbase-mm", "1e9"], "1e+09 mm is no wheelbase (a robot's is 20 to 10000 mm)"),
    ):
        code, _, err = run(capsys, "simulate", *flags, "--out", str(tmp_path / "x.csv"))
        assert code == 2 and err.count("\n") == 1 and match in err, (flags, err)
    code, _, err = run(capsys, "simulate", "--out", str(tmp_path / "nodir" / "x.csv"))
    assert code == 2 and "does not exist" in err
    assert not (tmp_path / "x.csv").exists()


def test_demo_writes_plot_and_shows_improvement(tmp_path, capsys):
    code, out, err = run(capsys, "demo", "--out", str(tmp_path), "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["before"]["emax_syst_mm"] > 200
    assert d["improvement"] > 5
    png = tmp_path / "umbmark-demo-scatter.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = run(capsys, "demo", "--out", str(tmp_path))
    assert code == 0 and "improvement" in out and "Before / after" in out


def test_demo_is_reproducible(tmp_path, capsys):
    a = json.loads(run(capsys, "demo", "--out", str(tmp_path), "--json", "--seed", "4")[1])
    b = json.loads(run(capsys, "demo", "--out", str(tmp_path), "--json", "--seed", "4")[1])
    assert a["after"] == b["after"]


def test_console_script_has_no_traceback(tmp_path):
    """The installed entry point, in a fresh process: one line, exit 2."""
    p = subprocess.run(
        [
            sys.executable,
            "-c",
            "from umbmark.cli import main; main()",
            "analyze",
            str(tmp_path / "none.csv"),
            "--wheelbase-mm",
            "340",
            "--side-mm",
            "4000",
        ],
        capture_output=True,
        text=True,
    )
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and p.stderr.count("\n") == 1


def test_plot_format_must_be_one_matplotlib_writes(tmp_path, capsys):
    f = tmp_path / "r.csv"
    f.write_text("direction,x_abs,y_abs,x_odo,y_odo\ncw,-60,-60,0,0\nccw,60,-60,0,0\n")
    bad = tmp_path / "out.xyz"
    code, _, err = run(capsys, "analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(bad))
    assert code == 2 and err.count("\n") == 1 and "cannot write a .xyz figure" in err and str(bad) in err
    assert not bad.exists()
    ok = tmp_path / "out.SVG"
    assert run(capsys, "analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--plot", str(ok))[0] == 0
    assert ok.read_bytes().lstrip().startswith(b"<?xml")


def _keys(obj) -> set[str]:
    if isinstance(obj, dict):
        return set(obj) | {k for v in obj.values() for k in _keys(v)}
    if isinstance(obj, list):
        return {k for v in obj for k in _keys(v)}
    return set()


def _headers_and_labels(text: str) -> list[str]:
    """The column headers and the first-column labels of the tables in ``text`` (rich boxes)."""
    cells = []
    for line in text.splitlines():
        if line.startswith("┃"):
            cells += [c.strip() for c in line.strip("┃").split("┃")]
        elif line.startswith("│"):
            cells.append(line.strip("│").split("│")[0].strip())
    return [c for c in cells if c]


def _text_and_json(capsys, monkeypatch, *args):
    monkeypatch.setenv("COLUMNS", "80")
    code, text, err = run(capsys, *args)
    assert code == 0, err
    code, out, err = run(capsys, *args, "--json")
    assert code == 0, err
    return text, json.loads(out)


def _check_newcomer_text(text: str, d: dict, shown: list[str], paths=()):
    # commands to copy and file names are printed unbroken; everything else fits 80 columns
    unbroken = [ln for ln in text.splitlines() if ln.startswith("  umbmark") or any(str(p) in ln for p in paths)]
    assert max(len(line) for line in text.splitlines() if line not in unbroken) <= 80
    assert "…" not in text  # nothing cut to fit
    for s in shown:
        assert s in text, f"{s!r} is not printed in full"
    raw = {k for k in _keys(d) if "_" in k} - {"c_left", "c_right"}  # c_left, c_right: the paper's names
    for cell in _headers_and_labels(text):
        assert cell not in raw and not any(k in cell for k in raw if len(k) > 6), f"raw JSON key in {cell!r}"
    for word in ("E_max,syst", "3 x SEM", "E_d", "E_b", "c_left", "wheelbase", "SEM = std / sqrt(runs)"):
        assert word in text
    nxt = text[text.index("Next") :]
    assert "umbmark export" in nxt and "--format ros2" in nxt


def test_analyze_text_explains_every_figure_at_80_columns(tmp_path, capsys, monkeypatch):
    f = tmp_path / "runs.csv"
    run(capsys, "simulate", "--ed", "1.002", "--eb", "0.99", "--seed", "1", "--noise", "paper", "--out", str(f))
    for method in ("bf", "exact"):
        text, d = _text_and_json(
            capsys, monkeypatch, "analyze", str(f), "--wheelbase-mm", "340", "--side-mm", "4000", "--method", method
        )
        shown = [
            f"{d['emax_syst_mm']:.1f} mm",
            f"{d['three_sem_mm']:.1f} mm",
            f"{d['Ed']:.6f}",
            f"{d['Eb']:.6f}",
            f"{d['c_left']:.6f}",
            f"{d['c_right']:.6f}",
            f"{d['wheelbase_corrected_mm']:.2f}",
            f"{d['alpha_deg']:.4f}",
            f"{d['beta_deg']:.4f}",
        ] + [f"{d[s][k]:.1f}" for s in ("cw", "ccw") for k in ("x_cg_mm", "y_cg_mm", "r_cg_mm", "std_mm", "sem_mm")]
        if method == "exact":
            shown += [f"{v:.6f}" for v in d["Ed_ci95"] + d["Eb_ci95"]]
            shown += [f"{v:.2f}" for v in d["wheelbase_corrected_mm_ci95"]]
            shown += [f"{d['emax_syst_after_pred_mm']:.1f} / {d['emax_syst_after_pred_measured_mm']:.1f}"]
        _check_newcomer_text(text, d, shown, paths=[tmp_path])
        # the commands of the next step: the second pass with the calibration loaded, and the export
        assert d["second_pass_recommended"]
        assert f"--wheelbase-mm {d['wheelbase_corrected_mm']:.2f}" in text
        assert f"--c-left {d['c_left']:.6f} --c-right {d['c_right']:.6f}" in text
        assert f"umbmark analyze {f} --wheelbase-mm 340 --side-mm 4000" in text


def test_analyze_says_when_a_further_pass_is_not_expected_to_help(tmp_path, capsys, monkeypatch):
    """Runs of a calibrated robot (E_max,syst below 3 x SEM): no second-pass command; the factors
    and the export command of the runs as they were made (with their calibration) are shown."""
    f = tmp_path / "after.csv"
    args = ["--c-left", "0.999032", "--c-right", "1.000968"]
    code, _, err = run(
        capsys,
        "simulate",
        "--ed",
        "1.002",
        "--eb",
        "0.99",
        "--seed",
        "2",
        "--noise",
        "paper",
        *args,
        "--model-wheelbase-mm",
        "336.69",
        "--out",
        str(f),
    )
    assert code == 0, err
    text, d = _text_and_json(
        capsys, monkeypatch, "analyze", str(f), "--wheelbase-mm", "336.69", "--side-mm", "4000", *args
    )
    assert not d["second_pass_recommended"]
    assert "not expected to help" in text and "NEW.csv" not in text
    assert f"c_left = {d['c_left']:.6f}, c_right = {d['c_right']:.6f}" in text
    assert "--wheelbase-mm 336.69 --side-mm 4000 --c-left 0.999032 --c-right 1.000968 --json > cal.json" in text


def test_demo_text_explains_every_figure_at_80_columns(tmp_path, capsys, monkeypatch):
    text, d = _text_and_json(capsys, monkeypatch, "demo", "--out", str(tmp_path))
    b, a = d["before"], d["after"]
    shown = [
        f"{d['true_Ed']:.5f}",
        f"{d['true_Eb']:.5f}",
        f"{d['true_wheelbase_mm']:.2f} mm",
        f"{b['Ed']:.6f}",
        f"{b['Eb']:.6f}",
        f"{b['emax_syst_mm']:.1f}",
        f"{a['emax_syst_mm']:.1f}",
        f"{b['three_sem_mm']:.1f}",
        f"{a['three_sem_mm']:.1f}",
        f"{b['c_left']:.6f} / {b['c_right']:.6f}",
        f"{b['wheelbase_corrected_mm']:.2f}",
        f"{d['improvement']:.1f}-fold",
        d["files"]["scatter_png"],
    ]
    _check_newcomer_text(text, d, shown, paths=[tmp_path])
    assert "umbmark guide" in text


def test_demo_json_is_the_library_result(tmp_path, capsys):
    """The CLI prints the library's DemoResult.to_dict() as it is."""
    from umbmark.jsonutil import jsonable
    from umbmark.studies.demo import FILE_NAMES, demo

    code, out, _ = run(capsys, "demo", "--out", str(tmp_path), "--seed", "3", "--runs", "3", "--json")
    assert code == 0
    r = demo(seed=3, n_runs=3)
    assert "files" not in r.to_dict()
    saved = r.save(tmp_path)
    assert saved.files == {k: str(tmp_path / name) for k, name in FILE_NAMES.items()}
    assert json.loads(out) == jsonable(saved.to_dict())
    assert list(json.loads(out)) == list(saved.to_dict())
