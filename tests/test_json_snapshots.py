"""Snapshot tests of the CLI's machine-readable output: every ``--json`` command and the
deterministic files that ``simulate --out``, ``demo``, ``measure``, ``export``, ``convert``,
``history --export`` and ``replay --poses-out`` write, pinned in ``tests/snapshots/CASE.json``.

The CLI runs in-process through ``umbmark.cli.main`` only (no library module is imported here,
so that the modules can move); the inputs are fixed: seeded simulations, ``data/`` and logs and
bags written from ``tests/simlogs.py`` (noise free).

Rule (:func:`assert_matches`): every key of the snapshot must be in the new output with an
equal value (numbers to 1e-6 relative or 1e-6 absolute: the fits are iterative and stop within
their tolerances, where another release of scipy or numpy may take one step more or less;
strings exactly after the paths are normalised, lists element by element and of the same
length; an ``improvement`` ratio of a noise-free log, whose error after is at rounding, only
beyond 1e9 either way); new keys are allowed. The keys in :data:`NOT_COMPARED` (timestamps, versions, host,
timings, memory, the machine, the solver's evaluation count) must be present but their values
are never compared (stored as ``"<not compared>"``).

Regenerate (after a deliberate change of the numbers only)::

    UMBMARK_UPDATE_SNAPSHOTS=1 pytest tests/test_json_snapshots.py

Without the variable a missing snapshot is a failure.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
import simlogs
import yaml
from conftest import REPO

from umbmark.cli import main

SNAPSHOTS = Path(__file__).resolve().parent / "snapshots"
UPDATE = os.environ.get("UMBMARK_UPDATE_SNAPSHOTS") == "1"
REL_TOL, ABS_TOL = 1e-6, 1e-6
# an improvement (the error before over the error after) beyond this divides by an error at rounding
ROUNDING_RATIO = 1e9
OPTIODOM = REPO / "data" / "optiodom"
DISTANCES = REPO / "data" / "examples" / "distances.csv"

# Keys (at any depth) whose values are not compared: only their presence is checked.
NOT_COMPARED = frozenset(
    {
        # when / where / with what the command ran (history records)
        "time_utc",
        "first_utc",
        "last_utc",
        "software_version",
        "host",
        # bench speed: timings, throughput, memory and the machine
        "seconds",
        "cpu_seconds",
        "generation_seconds",
        "samples_per_s",
        "samples_per_s_wall",
        "samples_per_s_cpu",
        "experiments_per_s",
        "experiments_per_s_wall",
        "experiments_per_s_cpu",
        "x_reference",
        "rss_base_mib",
        "rss_peak_mib",
        "machine",
        # bench accuracy: its wall-clock time
        "elapsed_s",
        # the solver's count of evaluations (another release of scipy may take another step)
        "fit_nfev",
    }
)
PLACEHOLDER = "<not compared>"


# -- comparison ---------------------------------------------------------------------------------------
def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _diff(expected, actual, where: str, out: list[str]) -> None:
    if isinstance(expected, dict):
        if not isinstance(actual, dict):
            out.append(f"{where}: expected an object, got {type(actual).__name__}")
            return
        for k, v in expected.items():
            if k not in actual:
                out.append(f"{where}.{k}: missing")
            elif k not in NOT_COMPARED:
                _diff(v, actual[k], f"{where}.{k}", out)
    elif isinstance(expected, list):
        if not isinstance(actual, list):
            out.append(f"{where}: expected a list, got {type(actual).__name__}")
        elif len(expected) != len(actual):
            out.append(f"{where}: {len(actual)} elements, expected {len(expected)}")
        else:
            for i, (e, a) in enumerate(zip(expected, actual)):
                _diff(e, a, f"{where}[{i}]", out)
    elif _is_number(expected):
        if where.endswith(".improvement") and _is_number(actual) and min(actual, expected) > ROUNDING_RATIO:
            return  # before over an after at rounding: its value is the rounding's, not the fit's
        if not _is_number(actual) or not math.isclose(actual, expected, rel_tol=REL_TOL, abs_tol=ABS_TOL):
            out.append(f"{where}: {actual!r}, expected {expected!r}")
    elif expected != actual or type(expected) is not type(actual):  # str, bool, None
        out.append(f"{where}: {actual!r}, expected {expected!r}")


def assert_matches(expected, actual, name: str = "$") -> None:
    """Every key of ``expected`` present in ``actual`` with an equal value (see the module
    docstring); all differences are listed."""
    out: list[str] = []
    _diff(expected, actual, name, out)
    if out:
        more = f"\n... and {len(out) - 30} more" if len(out) > 30 else ""
        pytest.fail(f"{len(out)} difference(s) from the snapshot:\n" + "\n".join(out[:30]) + more, pytrace=False)


def _stored(v):
    """The output as stored in a snapshot: values of NOT_COMPARED keys replaced."""
    if isinstance(v, dict):
        return {k: (PLACEHOLDER if k in NOT_COMPARED else _stored(x)) for k, x in v.items()}
    if isinstance(v, list):
        return [_stored(x) for x in v]
    return v


class Normaliser:
    """Temporary and repository folders in strings become <tmp>, <inputs> and <repo>."""

    def __init__(self, **roots: Path):
        pairs = []
        for label, p in roots.items():
            for s in {str(p), str(Path(p).resolve())}:
                pairs.append((s, f"<{label}>"))
        self.pairs = sorted(pairs, key=lambda x: -len(x[0]))

    def __call__(self, v):
        if isinstance(v, str):
            for s, label in self.pairs:
                v = v.replace(s, label)
            return v
        if isinstance(v, dict):
            return {k: self(x) for k, x in v.items()}
        if isinstance(v, list):
            return [self(x) for x in v]
        return v


# -- reading what the CLI printed or wrote ------------------------------------------------------------
def _cell(s: str):
    try:
        x = float(s)
    except ValueError:
        return s
    return x if math.isfinite(x) else None


def parse_csv(path: Path, sample_every: int | None = None) -> dict:
    """Header and rows of a CSV file, numbers as numbers. With ``sample_every`` (long logs) only
    every N-th row and the last one are kept, with the row count and each numeric column's sum."""
    rows = [[_cell(c) for c in r] for r in csv.reader(io.StringIO(Path(path).read_text()))]
    head = [r for r in rows if r and isinstance(r[0], str) and r[0].startswith("#")]
    body = [r for r in rows if r and r not in head]
    header, data = body[0], body[1:]
    if sample_every is None:
        return {"comments": head, "header": header, "rows": data}
    cols = list(zip(*data))
    sums = [float(sum(c)) if all(_is_number(x) for x in c) else None for c in cols]
    keep = sorted(set(range(0, len(data), sample_every)) | {len(data) - 1})
    return {
        "comments": head,
        "header": header,
        "n_rows": len(data),
        "column_sums": sums,
        "rows_sampled": {str(i): data[i] for i in keep},
    }


def parse_text(path: Path) -> list:
    """Lines of a text file, split on white space, numeric tokens as numbers."""
    return [[_cell(t) for t in line.split()] for line in Path(path).read_text().splitlines()]


class Cli:
    """Runs ``umbmark ARGS`` in-process in the test's folder and parses its JSON."""

    def __init__(self, capsys):
        self.capsys = capsys

    def __call__(self, *args, as_json: bool = True):
        args = [str(a) for a in args]
        self.capsys.readouterr()
        code = main(args)
        cap = self.capsys.readouterr()
        assert code == 0, f"umbmark {' '.join(args)} -> exit {code}\n{cap.err}"
        return json.loads(cap.out) if as_json else cap.out


# -- fixed inputs: logs and bags from tests/simlogs.py ------------------------------------------------
NOMINAL_LOG = ["--wheel-diameter-mm", "100", "--wheelbase-mm", "300"]  # simlogs.GEOM
PULSES = ["--pulses-per-wheel-rev", "1000"]


def _write_generic_csv(path: Path, runs) -> Path:
    """A generic CSV log (run column, cumulative whole pulses, ground truth) of simlogs runs."""
    lines = ["run,time_s,left_ticks,right_ticks,x_m,y_m,theta_rad"]
    for r in runs:
        cl, cr = np.cumsum(np.round(r.d_left)), np.cumsum(np.round(r.d_right))
        for k in range(len(r.t)):
            vals = (r.t[k], cl[k], cr[k], *r.gt[k])
            lines.append(",".join([r.name] + [repr(round(float(v), 9)) for v in vals]))
    path.write_text("\n".join(lines) + "\n")
    return path


def _write_bag(path: Path, pos_l, pos_r, gt, ros1: bool, dt: float = 0.02, t0: int = 1_700_000_000) -> Path:
    """A bag with /joint_states (wheel angles) and ground truth: ROS 2 mcap with
    geometry_msgs/PoseStamped on /mocap/pose, or ROS 1 with nav_msgs/Odometry on /ground_truth."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    T = ts.types
    msgs = []
    for k in range(len(pos_l)):
        t = t0 + k * dt
        ns = int(round(t * 1e9))
        stamp = T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))
        hk = {"seq": k} if ros1 else {}
        hdr = T["std_msgs/msg/Header"](stamp=stamp, frame_id="", **hk)
        msgs.append(
            (
                "/joint_states",
                "sensor_msgs/msg/JointState",
                ns,
                T["sensor_msgs/msg/JointState"](
                    header=hdr,
                    name=["wheel_left", "caster", "wheel_right"],
                    position=np.array([pos_l[k], 0.3, pos_r[k]]),
                    velocity=np.array([], float),
                    effort=np.array([], float),
                ),
            )
        )
        x, y, th = gt[k]
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
        )
        whdr = T["std_msgs/msg/Header"](stamp=stamp, frame_id="world", **hk)
        if ros1:
            cov = np.zeros(36)
            v0 = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            msgs.append(
                (
                    "/ground_truth",
                    "nav_msgs/msg/Odometry",
                    ns,
                    T["nav_msgs/msg/Odometry"](
                        header=whdr,
                        child_frame_id="robot",
                        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
                        twist=T["geometry_msgs/msg/TwistWithCovariance"](
                            twist=T["geometry_msgs/msg/Twist"](linear=v0, angular=v0), covariance=cov
                        ),
                    ),
                )
            )
        else:
            msgs.append(
                (
                    "/mocap/pose",
                    "geometry_msgs/msg/PoseStamped",
                    ns,
                    T["geometry_msgs/msg/PoseStamped"](header=whdr, pose=pose),
                )
            )
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer as w:
        conns = {}
        for topic, mtype, ns, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, mtype, typestore=ts)
            w.write(conns[topic], ns, ts.serialize_ros1(msg, mtype) if ros1 else ts.serialize_cdr(msg, mtype))
    return path


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("inputs")
    squares = simlogs.dataset(simlogs.squares(2), side_m=2.0)
    general = simlogs.dataset([simlogs.general_program()])
    al, ar, pose = simlogs.simulate_wheels(simlogs.general_program())
    gt = simlogs.world(pose)
    return {
        "dir": d,
        "csv_squares": _write_generic_csv(d / "squares.csv", squares.runs),
        "csv_general": _write_generic_csv(d / "general.csv", general.runs),
        "bag_mcap": _write_bag(d / "bag_mcap", np.cumsum(al), np.cumsum(ar), gt, ros1=False),
        "bag_ros1": _write_bag(d / "run.bag", np.cumsum(al), np.cumsum(ar), gt, ros1=True),
    }


# -- the cases: each returns the object stored as tests/snapshots/NAME.json ---------------------------
SQUARE = OPTIODOM / "square" / "230620202144"
SQUARE2 = OPTIODOM / "square" / "231220200029"
CIRCULAR = OPTIODOM / "circular" / "231220200157"
FREE = OPTIODOM / "free" / "030120210006"
IVANJKO = OPTIODOM / "ivanjko" / "231220200104"
SIM1 = ["simulate", "--ed", "1.002", "--eb", "0.99", "--runs", "5", "--seed", "1", "--noise", "paper"]
SIM2 = [
    "simulate",
    "--ed",
    "1.002",
    "--eb",
    "0.99",
    "--runs",
    "5",
    "--seed",
    "2",
    "--noise",
    "paper",
    "--c-left",
    "0.999032",
    "--c-right",
    "1.000968",
    "--model-wheelbase-mm",
    "336.69",
]
LABMATE = ["--wheelbase-mm", "340", "--side-mm", "4000"]
MEASURE = ["measure", DISTANCES, "--front", "150,-120", "--rear", "-150,-120", "--back", "-200,0"]

CASES = {}


def case(f):
    CASES[f.__name__] = f
    return f


@case
def simulate_paper(cli, inp):
    return {"stdout": cli(*SIM1, "--out", "runs.csv", "--json"), "runs.csv": parse_csv(Path("runs.csv"))}


@case
def simulate_second_pass(cli, inp):
    return {"stdout": cli(*SIM2, "--out", "after.csv", "--json"), "after.csv": parse_csv(Path("after.csv"))}


@case
def simulate_geometry_options(cli, inp):
    out = cli(
        "simulate",
        "--ed",
        "0.995",
        "--eb",
        "1.03",
        "--es",
        "1.01",
        "--runs",
        "3",
        "--seed",
        "3",
        "--wheelbase-mm",
        "300",
        "--side-mm",
        "2000",
        "--wheel-diameter-mm",
        "100",
        "--sample-period-ms",
        "20",
        "--speed",
        "0.3",
        "--out",
        "r.csv",
        "--json",
    )
    return {"stdout": out, "r.csv": parse_csv(Path("r.csv"))}


@case
def analyze_bf(cli, inp):
    cli(*SIM1, "--out", "runs.csv", "--json")
    return cli("analyze", "runs.csv", *LABMATE, "--method", "bf", "--json")


@case
def analyze_exact(cli, inp):
    cli(*SIM1, "--out", "runs.csv", "--json")
    return cli("analyze", "runs.csv", *LABMATE, "--method", "exact", "--json")


@case
def analyze_exact_soft_l1_straight(cli, inp):
    cli(*SIM1, "--out", "runs.csv", "--json")
    return cli(
        "analyze",
        "runs.csv",
        *LABMATE,
        "--method",
        "exact",
        "--loss",
        "soft_l1",
        "--straight-mm",
        "4000",
        "4010",
        "--json",
    )


@case
def analyze_second_pass(cli, inp):
    cli(*SIM2, "--out", "after.csv", "--json")
    return cli(
        "analyze",
        "after.csv",
        "--wheelbase-mm",
        "336.69",
        "--side-mm",
        "4000",
        "--c-left",
        "0.999032",
        "--c-right",
        "1.000968",
        "--json",
    )


@case
def analyze_measured(cli, inp):
    cli(*MEASURE, "--out", "m.csv", "--json")
    return cli("analyze", "m.csv", *LABMATE, "--json")


@case
def demo(cli, inp):
    Path("demo").mkdir()
    out = cli("demo", "--out", "demo", "--json")
    return {
        "stdout": out,
        "before.csv": parse_csv(Path("demo/umbmark-demo-before.csv")),
        "after.csv": parse_csv(Path("demo/umbmark-demo-after.csv")),
    }


@case
def demo_no_noise(cli, inp):
    return cli("demo", "--out", ".", "--seed", "3", "--runs", "2", "--noise", "none", "--json")


@case
def measure_example(cli, inp):
    return {"stdout": cli(*MEASURE, "--out", "m.csv", "--json"), "m.csv": parse_csv(Path("m.csv"))}


@case
def measure_resolution(cli, inp):
    return {
        "stdout": cli(*MEASURE, "--resolution-mm", "5", "--out", "m.csv", "--json"),
        "m.csv": parse_csv(Path("m.csv")),
    }


@case
def calibrate_simulated_exact(cli, inp):
    return cli("calibrate", "--ed", "1.02", "--eb", "0.95", "--seed", "1", "--json")


@case
def calibrate_simulated_bf_saved(cli, inp):
    Path("passes").mkdir()
    out = cli(
        "calibrate",
        "--method",
        "bf",
        "--runs",
        "3",
        "--seed",
        "2",
        "--max-passes",
        "2",
        "--sample-period-ms",
        "20",
        "--save-runs",
        "passes",
        "--json",
    )
    return {"stdout": out, **{p.name: parse_csv(p) for p in sorted(Path("passes").glob("*.csv"))}}


@case
def calibrate_files(cli, inp):
    Path("passes").mkdir()
    cli(
        "calibrate",
        "--method",
        "bf",
        "--runs",
        "3",
        "--seed",
        "2",
        "--max-passes",
        "2",
        "--sample-period-ms",
        "20",
        "--save-runs",
        "passes",
        "--json",
    )
    files = sorted(str(p) for p in Path("passes").glob("pass*.csv"))
    assert len(files) >= 2
    return cli("calibrate", *files, "--method", "bf", *LABMATE, "--json")


@case
def history_and_report(cli, inp):
    db = ["--db", "h.sqlite"]
    out = {}
    cli(*SIM1, "--out", "runs.csv", "--json")
    out["analyze_record"] = cli("analyze", "runs.csv", *LABMATE, "--robot", "r1", "--record", *db, "--json")
    out["calibrate_record"] = cli(
        "calibrate", "--seed", "1", "--runs", "2", "--max-passes", "1", "--robot", "r1", "--record", *db, "--json"
    )
    out["replay_record"] = cli("replay", SQUARE, "--no-heldout", "--robot", "opti", "--record", *db, "--json")
    out["history"] = cli("history", *db, "--json")
    out["history_r1"] = cli("history", "r1", *db, "--json")
    out["history_r1_limit"] = cli("history", "r1", "--limit", "1", *db, "--json")
    out["history_show_1"] = cli("history", "--show", "1", *db, "--json")
    out["history_show_3"] = cli("history", "--show", "3", *db, "--json")
    out["history_export_json"] = cli("history", "r1", *db, "--export", "p.json", "--json")
    out["p.json"] = json.loads(Path("p.json").read_text())
    cli("history", "opti", *db, "--export", "p.yaml", as_json=False)
    out["p.yaml"] = yaml.safe_load(Path("p.yaml").read_text())
    out["report_history"] = cli("report", "--robot", "r1", *db, "--out", "r1.html", "--json")
    return out


@case
def report_analysis(cli, inp):
    cli(*SIM1, "--out", "runs.csv", "--json")
    cli(*SIM2, "--out", "after.csv", "--json")
    return cli(
        "report",
        "runs.csv",
        *LABMATE,
        "--after",
        "after.csv",
        "--bootstrap",
        "200",
        "--seed",
        "3",
        "--out",
        "report.html",
        "--json",
    )


@case
def replay_square_bf(cli, inp):
    return cli("replay", SQUARE, "--method", "bf", "--json")


@case
def replay_square_exact(cli, inp):
    return cli("replay", SQUARE, "--format", "optiodom", "--method", "exact", "--json")


@case
def replay_square_lsq(cli, inp):
    return cli("replay", SQUARE, "--method", "lsq", "--json")


@case
def replay_square_lsq_end_fixed(cli, inp):
    return cli("replay", SQUARE, "--method", "lsq", "--lsq-mode", "end", "--scale", "fixed", "--no-heldout", "--json")


@case
def replay_circular_lsq(cli, inp):
    return cli("replay", CIRCULAR, "--method", "lsq", "--json")


@case
def replay_free_lsq_marker_offset(cli, inp):
    return cli(
        "replay",
        FREE,
        "--method",
        "lsq",
        "--lsq-mode",
        "sampled",
        "--points-per-run",
        "30",
        "--heading-weight-m",
        "1.0",
        "--fit-marker-offset",
        "--json",
    )


@case
def replay_ivanjko_lsq(cli, inp):
    return cli("replay", IVANJKO, "--method", "lsq", "--json")


@case
def replay_two_squares_bf(cli, inp):
    return cli("replay", SQUARE, SQUARE2, "--method", "bf", "--json")


@case
def replay_pool_lsq(cli, inp):
    return cli("replay", CIRCULAR, IVANJKO, "--method", "lsq", "--pool", "--json")


@case
def replay_csv_squares_bf(cli, inp):
    return cli("replay", inp["csv_squares"], "--method", "bf", "--side-mm", "2000", *NOMINAL_LOG, *PULSES, "--json")


@case
def replay_csv_squares_lsq(cli, inp):
    return cli(
        "replay",
        inp["csv_squares"],
        "--format",
        "csv",
        "--method",
        "lsq",
        "--side-mm",
        "2000",
        *NOMINAL_LOG,
        *PULSES,
        "--json",
    )


@case
def replay_csv_general_lsq(cli, inp):
    return cli("replay", inp["csv_general"], "--method", "lsq", *NOMINAL_LOG, *PULSES, "--json")


@case
def replay_csv_stream(cli, inp):
    out = cli(
        "replay",
        inp["csv_general"],
        "--stream",
        "--decimate",
        "10",
        "--poses-out",
        "poses.csv",
        *NOMINAL_LOG,
        *PULSES,
        "--json",
    )
    return {"stdout": out, "poses.csv": parse_csv(Path("poses.csv"))}


@case
def replay_bag_ros2_mcap_lsq(cli, inp):
    return cli(
        "replay",
        inp["bag_mcap"],
        "--method",
        "lsq",
        "--joints",
        "wheel_left,wheel_right",
        "--gt-topic",
        "/mocap/pose",
        *NOMINAL_LOG,
        "--json",
    )


@case
def replay_bag_ros1_lsq(cli, inp):
    return cli(
        "replay",
        inp["bag_ros1"],
        "--format",
        "bag",
        "--method",
        "lsq",
        "--joints",
        "wheel_left,wheel_right",
        "--gt-topic",
        "/ground_truth",
        *NOMINAL_LOG,
        "--json",
    )


@case
def bag_info(cli, inp):
    return {"mcap": cli("bag-info", inp["bag_mcap"], "--json"), "ros1": cli("bag-info", inp["bag_ros1"], "--json")}


def _export(cli, fmt, *extra, cal=True):
    if cal:
        cli("replay", SQUARE, "--method", "bf", "--no-heldout", "--save", "cal.json", "--json")
    out = "params.json" if fmt == "json" else "params.h" if fmt == "firmware" else "params.yaml"
    cli("export", *(["cal.json"] if cal else []), "--format", fmt, *extra, "--out", out, as_json=False)
    text = Path(out).read_text()
    if fmt == "json":
        return {out: json.loads(text)}
    if fmt == "firmware":
        return {out: parse_text(Path(out))}
    return {out: yaml.safe_load(text), "comments": [line for line in text.splitlines() if line.startswith("#")]}


@case
def export_ros2(cli, inp):
    return _export(cli, "ros2")


@case
def export_ros2_multipliers(cli, inp):
    return _export(
        cli,
        "ros2",
        "--controller",
        "my_controller",
        "--left-multiplier",
        "1.01",
        "--right-multiplier",
        "0.99",
        "--separation-multiplier",
        "1.02",
        "--wheel-radius-m",
        "0.042",
        "--wheel-separation-m",
        "0.2",
    )


@case
def export_ros1(cli, inp):
    return _export(cli, "ros1")


@case
def export_json(cli, inp):
    return _export(cli, "json")


@case
def export_firmware(cli, inp):
    return _export(cli, "firmware")


@case
def export_firmware_command_line(cli, inp):
    return _export(
        cli,
        "firmware",
        "--c-left",
        "0.999",
        "--c-right",
        "1.001",
        "--eb",
        "0.98",
        "--wheel-diameter-mm",
        "150",
        "--wheelbase-mm",
        "340",
        "--pulses-per-wheel-rev",
        "2048",
        cal=False,
    )


@case
def export_json_from_analyze(cli, inp):
    cli(*SIM1, "--out", "runs.csv", "--json")
    Path("cal.json").write_text(json.dumps(cli("analyze", "runs.csv", *LABMATE, "--json")))
    cli("export", "cal.json", "--format", "json", "--wheel-diameter-mm", "150", "--out", "params.json", as_json=False)
    return json.loads(Path("params.json").read_text())


@case
def convert_optiodom_runs(cli, inp):
    cli("convert", SQUARE, "--to", "runs", "--out", "runs.csv", as_json=False)
    return parse_csv(Path("runs.csv"))


@case
def convert_optiodom_csv(cli, inp):
    cli("convert", IVANJKO, "--format", "optiodom", "--out", "log.csv", as_json=False)
    return parse_csv(Path("log.csv"), sample_every=20)


@case
def convert_bag_csv(cli, inp):
    cli(
        "convert",
        inp["bag_mcap"],
        "--joints",
        "wheel_left,wheel_right",
        "--gt-topic",
        "/mocap/pose",
        *NOMINAL_LOG,
        "--out",
        "log.csv",
        as_json=False,
    )
    return parse_csv(Path("log.csv"), sample_every=20)


@case
def convert_csv_runs(cli, inp):
    cli(
        "convert",
        inp["csv_squares"],
        "--side-mm",
        "2000",
        *NOMINAL_LOG,
        *PULSES,
        "--to",
        "runs",
        "--out",
        "runs.csv",
        as_json=False,
    )
    return parse_csv(Path("runs.csv"))


@case
def reproduce_small(cli, inp):
    return cli("reproduce", "--seeds", "2", "--workers", "1", "--json")


@case
def bench_accuracy_quick(cli, inp):
    return cli("bench", "accuracy", "--quick", "--robots", "1", "--workers", "1", "--out", "acc", "--json")


@case
def bench_speed_quick(cli, inp):
    return cli(
        "bench",
        "speed",
        "--quick",
        "--replay-sizes",
        "10000",
        "--robots",
        "1",
        "--workers",
        "1",
        "--out",
        "speed",
        "--json",
    )


# -- the tests ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(CASES))
def test_snapshot(name, tmp_path, monkeypatch, capsys, inputs):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("UMBMARK_DB", str(tmp_path / "default-history.sqlite"))  # never the user's history
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    norm = Normaliser(tmp=tmp_path, inputs=inputs["dir"], repo=REPO)
    actual = norm(CASES[name](Cli(capsys), inputs))
    path = SNAPSHOTS / f"{name}.json"
    if UPDATE:
        SNAPSHOTS.mkdir(exist_ok=True)
        path.write_text(json.dumps(_stored(actual), indent=1) + "\n")
    elif not path.exists():
        pytest.fail(f"no snapshot {path.relative_to(REPO)}: generate it with UMBMARK_UPDATE_SNAPSHOTS=1", pytrace=False)
    assert_matches(json.loads(path.read_text()), actual, name)


def test_every_snapshot_has_a_case():
    orphans = sorted(p.name for p in SNAPSHOTS.glob("*.json") if p.stem not in CASES)
    assert not orphans, f"snapshots without a case (delete them or restore the case): {orphans}"


def test_comparison_rule():
    snap = {"a": 1.0, "b": [1, "x", None, True], "t": {"seconds": PLACEHOLDER}, "s": "<tmp>/out.csv"}
    assert_matches(
        snap, {"a": 1.0 + 1e-7, "b": [1, "x", None, True], "t": {"seconds": 3.2}, "s": "<tmp>/out.csv", "new_key": 5}
    )
    assert_matches({"z": 0.0}, {"z": 1e-7})
    assert_matches({"fit_nfev": PLACEHOLDER}, {"fit_nfev": 14})
    for bad in (
        {"a": 1.0 + 1e-5},
        {"b": [1, "x", None]},
        {"b": [1, "y", None, True]},
        {"b": [1, "x", 0, True]},
        {"b": [1, "x", None, 1]},
        {"t": {}},
        {},
    ):
        with pytest.raises(pytest.fail.Exception):
            assert_matches(
                snap,
                {**{"a": 1.0, "b": [1, "x", None, True], "t": {"seconds": 1}, "s": "<tmp>/out.csv"}, **bad}
                if bad
                else {"a": 1.0},
            )
