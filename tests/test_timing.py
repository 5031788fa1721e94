"""umbmark.model.timing: stamp order, repeats, spikes, coverage, and the time offset between the
wheels and the ground truth (estimated from the turn rates; applied to data sets of CSV-like
runs)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import simlogs
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark._check import skipping_checks
from umbmark.errors import InputError
from umbmark.model.dataset import Dataset, Run
from umbmark.model.timing import (
    align_truth,
    check_streams,
    coverage,
    estimate_time_offset,
    ordered_stamps,
    parse_time_offset,
    wheel_spikes,
)
from umbmark.realrobot.replay import replay_report


def _turning(seed: int, duration_s: float = 60.0, dt: float = 0.01):
    """Times and the heading of a robot turning at a random, piecewise-constant rate."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, dt)
    pieces = rng.uniform(0.5, 3.0, 200).cumsum()
    rates = rng.choice([-0.8, 0.0, 0.0, 0.5, 1.0], 200)
    rate = rates[np.searchsorted(pieces, t) % 200]
    return t, np.concatenate([[0.0], np.cumsum(rate[1:] * dt)])


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    tau=st.floats(-2.0, 2.0),
    period=st.sampled_from([0.01, 0.02, 0.04, 0.1]),
    scale=st.floats(0.8, 1.25),
)
def test_offset_is_found_to_within_one_truth_period(seed, tau, period, scale):
    """A ground truth of any rate, late or early by up to 2 s, against wheels whose heading is
    scaled (a wrong wheelbase), with noise on the ground-truth heading."""
    t, h = _turning(seed)
    rng = np.random.default_rng(seed + 1)
    tg = np.arange(0.0, t[-1], period) + tau + rng.uniform(0, period)
    hg = np.interp(tg - tau, t, h) + rng.normal(0, 0.002, tg.size)
    est, corr, _, reason = estimate_time_offset(t, scale * h, tg, hg)
    assert reason is None and corr > 0.9
    assert abs(est - tau) < period


def test_no_offset_without_turns():
    t = np.arange(0, 10, 0.01)
    est, corr, _, reason = estimate_time_offset(t, np.zeros_like(t), t, np.zeros_like(t))
    assert est is None and "hardly turns" in reason


def test_unrelated_turn_rates_give_no_estimate():
    t, h = _turning(1)
    _, h2 = _turning(2)
    est, corr, _, reason = estimate_time_offset(t, h, t, -h2)
    assert est is None and "hardly agree" in reason


def test_ordered_stamps():
    keep, rep, first, moved = ordered_stamps([0.0, 0.1, 0.1, 0.2, 0.2, 0.2, 0.3], "joint states", "/js")
    assert list(keep) == [0, 2, 5, 6] and rep == 3 and first == 3 and moved == (0, 0.0)
    # a message delivered late (a step back of 15 ms at 100 Hz): put in stamp order
    keep, rep, first, moved = ordered_stamps([0.0, 0.01, 0.03, 0.015, 0.04], "joint states", "/js")
    assert list(keep) == [0, 1, 3, 2, 4] and rep == 0 and moved == (1, pytest.approx(0.015))
    # single messages delivered late with the stamp they were made at: put in stamp order
    t = np.arange(100) * 0.01
    late = np.concatenate([t[:50], t[10:11], t[50:60], t[20:23], t[60:]])  # 0.1 s and 0.2 s old, 1 and 3
    keep, rep, _, moved = ordered_stamps(late, "joint states", "/js")
    assert rep == 4 and moved[0] == 2 and np.all(np.diff(late[keep]) > 0)
    # a clock that jumps back (the messages after it go on from 0.5 s earlier): an error naming
    # the message, the check and its override
    jumped = np.concatenate([t, t[50:] + 0.001])
    msg = r"joint states on /js go backwards at message 101 of 150: 0.501000 s after .*`skip_checks=stamp_order`"
    with pytest.raises(InputError, match=msg):
        ordered_stamps(jumped, "joint states", "/js", "x.bag")
    with skipping_checks(["stamp_order"]):  # skipped: put in stamp order
        assert ordered_stamps(jumped, "joint states", "/js", "x.bag")[3][0] == 1
    with pytest.raises(InputError, match="not a number at message 2"):
        ordered_stamps([0.0, math.nan], "joint states", "/js")


def test_messages_out_of_order_are_sorted_with_a_warning():
    t = np.arange(10) * 0.01
    t[[4, 5]] = t[[5, 4]]
    pos = t * 10.0
    chk = check_streams(
        t, pos, pos, metres_per_unit_left=1e-3, metres_per_unit_right=1e-3, wheelbase_m=0.3, wheel_topic="/js"
    )
    assert np.all(np.diff(chk.t) > 0) and np.array_equal(chk.left, chk.t * 10.0)
    assert chk.warnings == (
        "1 of the 10 wheel positions on /js arrive out of stamp order (by up to 10.0 ms): put in stamp order",
    )


def test_wheel_spikes():
    t = np.arange(10) * 0.01
    pos = np.arange(10) * 0.01
    assert wheel_spikes(t, pos, pos, 0.05)[0].size == 0
    spiky = pos.copy()
    spiky[4] = 1e300
    bad, isolated = wheel_spikes(t, spiky, pos, 0.05)
    assert list(bad) == [4] and isolated
    jumped = pos.copy()
    jumped[6:] += 1e4
    bad, isolated = wheel_spikes(t, pos, jumped, 0.05)
    assert list(bad) == [6] and not isolated


def test_coverage():
    frac, gap, at = coverage(np.arange(0, 100.0), np.concatenate([np.arange(0, 10.0), np.arange(15.0, 20.0)]))
    assert frac == pytest.approx(19 / 99) and gap == 6.0 and at == 9.0


def test_parse_time_offset():
    assert parse_time_offset(None) is None and parse_time_offset(" ") is None
    assert parse_time_offset("AUTO") == "auto" and parse_time_offset("0.12") == 0.12
    assert parse_time_offset("-0.5s") == -0.5 and parse_time_offset(0.25) == 0.25
    for bad in ("soon", "nan", "1e9", math.inf):
        with pytest.raises(InputError, match="`time_offset`"):
            parse_time_offset(bad)


def test_incremental_counts_at_a_repeated_stamp_are_added():
    t = [0.0, 0.01, 0.01, 0.02, 0.03, 0.03]
    inc = [0.0, 1.0, 2.0, 3.0, 4.0, 4.0]  # two counts at 0.01 s; a message recorded twice at 0.03 s
    chk = check_streams(
        t,
        inc,
        inc,
        metres_per_unit_left=1e-3,
        metres_per_unit_right=1e-3,
        wheelbase_m=0.3,
        cumulative=False,
        wheel_topic="/ticks",
    )
    # the kept counts summed into positions: 0, 1 + 2, 3, 4 (once)
    assert list(chk.t) == [0.0, 0.01, 0.02, 0.03] and list(chk.left) == [0.0, 3.0, 6.0, 10.0]
    assert "1 of the 6 wheel positions on /ticks repeat the message before (the same stamp" in chk.warnings[0]
    assert "1 of the 5 wheel positions on /ticks repeat the stamp" in chk.warnings[1]


def _padded_squares(still_s: float = 3.0, dt: float = 0.02) -> Dataset:
    """Simulated square runs (wheels and ground truth in the same rows, as a CSV log), each with
    ``still_s`` of standstill before and after it."""
    ds = simlogs.dataset(simlogs.squares(2), dt=dt, side_m=2.0)
    n = int(round(still_s / dt))
    runs = []
    for r in ds.runs:
        z = np.zeros(n)
        gt = np.vstack([np.repeat(r.gt[:1], n, 0), r.gt, np.repeat(r.gt[-1:], n, 0)])
        k = len(r) + 2 * n
        runs.append(
            Run(r.name, np.arange(k) * dt, np.concatenate([z, r.d_left, z]), np.concatenate([z, r.d_right, z]), gt)
        )
    return ds.with_runs(runs)


def _late(ds: Dataset, tau: float) -> Dataset:
    """The ground truth of every run ``tau`` seconds late (the pose of t - tau in the row of t)."""
    runs = []
    for r in ds.runs:
        tt = np.clip(r.t - tau, r.t[0], r.t[-1])
        gt = np.column_stack([np.interp(tt, r.t, r.gt[:, c]) for c in range(3)])
        runs.append(Run(r.name, r.t, r.d_left, r.d_right, gt))
    return ds.with_runs(runs)


@pytest.mark.parametrize("tau", [0.1, 0.53, 1.9])
def test_align_truth_corrects_a_late_ground_truth_in_csv_runs(tau):
    clean = _padded_squares()
    late = _late(clean, tau)
    ref = replay_report(clean, "lsq", heldout=False).to_dict()
    bad = replay_report(late, "lsq", heldout=False).to_dict()
    fixed_ds = align_truth(late, "auto", "CSV log")
    entries = fixed_ds.meta["time_offset"]
    assert len(entries) == len(clean.runs)
    for e in entries:
        assert abs(e["estimated_s"] - tau) < e["truth_period_s"] and e["applied_s"] == pytest.approx(tau, abs=0.02)
    fixed = replay_report(fixed_ds, "lsq", heldout=False).to_dict()
    # measured: within 2e-8 in E_d and 7e-6 in E_b of the undelayed fit (lsq along the path)
    assert abs(fixed["Ed"] - ref["Ed"]) < 1e-6 and abs(fixed["Eb"] - ref["Eb"]) < 2e-5
    # the delay biased the uncorrected fit by far more (E_b by 1.2e-3 at 0.1 s, 3.9e-2 at 1.9 s)
    assert abs(bad["Eb"] - ref["Eb"]) > 1e-3
    assert align_truth(late, tau).meta["time_offset"][0]["applied_s"] == tau


def test_align_truth_needs_a_trajectory():
    ds = simlogs.dataset(simlogs.squares(1), side_m=2.0)
    bare = ds.with_runs([Run(r.name, r.t, r.d_left, r.d_right, None, r.gt[-1]) for r in ds.runs])
    with pytest.raises(InputError, match="needs a ground-truth trajectory"):
        align_truth(bare, "auto")
    assert align_truth(ds, None) is ds


def test_cli_time_offset_on_a_real_optiodom_folder(capsys):
    """The real OptiOdom squares: no delay beyond one motion-capture period (50 ms) is found, and
    correcting the tiny one found leaves the calibration as it was."""
    import json

    from conftest import REPO

    from umbmark.cli import main

    folder = str(REPO / "data" / "optiodom" / "square" / "230620202144")
    args = ["replay", folder, "--method", "bf", "--no-heldout", "--json"]
    assert main(args) == 0
    plain = json.loads(capsys.readouterr().out)
    assert "time_offset" not in plain
    assert main([*args, "--time-offset", "auto"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["time_offset"]) == len(d["runs"]) == 6
    for e in d["time_offset"]:
        assert abs(e["estimated_s"]) < e["truth_period_s"] == pytest.approx(0.05) and e["correlation"] > 0.9
    assert abs(d["Ed"] - plain["Ed"]) < 1e-4 and abs(d["Eb"] - plain["Eb"]) < 1e-4
    assert main([*args, "--time-offset", "0.1"]) == 0
    assert {e["applied_s"] for e in json.loads(capsys.readouterr().out)["time_offset"]} == {0.1}
    assert main([*args, "--time-offset", "later"]) == 2
    assert "--time-offset" in capsys.readouterr().err


@pytest.fixture(scope="module")
def drive():
    """A simulated drive of mixed motion (wheels at 100 Hz) and its true poses."""
    import dataclasses

    from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
    from umbmark.model.sensors import Lidar

    robot = dataclasses.replace(EXAMPLE_ROBOT, lidar=Lidar(n_beams=4, range_noise_m=0.0))
    return simulate_drive(mixed_program(60.0, seed=3, robot=robot), robot, scan_rate_hz=1.0)


def _streams(drive, tau: float, period: float, seed: int, noise_m: float = 5e-4):
    """The drive's wheel angles and a ground truth at ``period``, ``tau`` seconds late, with noise."""
    rng = np.random.default_rng(seed)
    t = drive.t_s
    tg = np.arange(rng.uniform(0, period), t[-1], period)
    pose = drive.true_pose_at(np.clip(tg, 0, t[-1]))
    pose = pose + rng.normal(0, 1, pose.shape) * [noise_m, noise_m, math.radians(0.1)]
    truth = np.column_stack([tg + tau, pose])
    g = drive.nominal_geometry
    kw = dict(
        metres_per_unit_left=g.diameter_left_m / 2,
        metres_per_unit_right=g.diameter_right_m / 2,
        wheelbase_m=g.wheelbase_m,
        wheel_topic="/joint_states",
        truth_topic="/mocap",
    )
    return (t + 1.7e9, drive.left_rad, drive.right_rad, truth + [1.7e9, 0, 0, 0]), kw


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 1000),
    late=st.floats(0.0, 1.9),
    sign=st.sampled_from([1.0, -1.0]),
    period=st.sampled_from([0.01, 0.02, 1 / 30, 0.1]),
)
def test_a_shifted_ground_truth_is_always_flagged_and_a_clean_one_never(drive, seed, late, sign, period):
    """Ground-truth stamps shifted by more than 50 ms and one sample period (either way) give a
    warning every time; the same streams unshifted (with motion-capture noise) give none."""
    tau = sign * (max(0.05, period) + 0.005 + late)
    args, kw = _streams(drive, tau, period, seed)
    chk = check_streams(*args, **kw)
    (w,) = chk.warnings
    assert "/mocap" in w and ("late" if tau > 0 else "early") in w and "`time_offset=auto`" in w
    # within one period, and (measured over 200 random cases: 2.5 ms at worst) within 5 ms
    assert abs(chk.time_offset.estimated_s - tau) < min(period, 0.005)
    fixed = check_streams(*args, **kw, time_offset="auto")
    assert fixed.warnings == () and abs(fixed.time_offset.applied_s - tau) < period
    clean_args, _ = _streams(drive, 0.0, period, seed)
    clean = check_streams(*clean_args, **kw)
    assert clean.warnings == () and abs(clean.time_offset.estimated_s) < period


def test_align_truth_warns_when_it_cuts_moving_samples():
    """Runs logged without stops around them: moving a late ground truth leaves the last moving
    samples without one, which is said (the square is left open)."""
    late = _late(simlogs.dataset(simlogs.squares(1), side_m=2.0), 0.3)
    out = align_truth(late, "auto")
    cut = [w for w in out.meta["warnings"] if "without a ground truth where the robot moves" in w]
    assert [w.split(":")[0] for w in cut] == [r.name for r in late.runs]
    assert all(len(a) == len(b) - 15 for a, b in zip(out.runs, late.runs))  # 0.3 s at 50 Hz
    assert align_truth(_late(_padded_squares(), 0.3), 0.3).meta["warnings"] == ()


@pytest.mark.parametrize("given", [-0.3, 0.1])
def test_a_given_time_offset_the_data_contradict_is_warned_about(given):
    """A ground truth 0.3 s late given as -0.3 s (the sign mixed up) or as 0.1 s: each run's
    warning names the estimate, and the sign where it is the given offset negated."""
    out = align_truth(_late(_padded_squares(), 0.3), given).meta["warnings"]
    notes = [w for w in out if w.startswith(f"`time_offset` {given:g} s was given")]
    assert len(notes) == len(_padded_squares().runs)
    assert all("0.300 s late" in w for w in notes)
    assert all(("the sign mixed up?" in w) == (given < 0) for w in notes)


def test_a_ground_truth_that_does_not_match_the_wheels_is_warned_about(drive):
    """The ground truth of another drive: the turn rates never line up, which is said."""
    args, kw = _streams(drive, 0.0, 0.01, 1)
    t, left, right, truth = args
    other = truth.copy()
    other[:, 3] = -truth[::-1, 3]  # the headings of the drive played backwards and mirrored
    chk = check_streams(t, left, right, other, **kw)
    (w,) = [w for w in chk.warnings if "do not line up" in w]
    assert "/joint_states" in w and "/mocap" in w and "hardly agree" in w and chk.time_offset.estimated_s is None
