"""umbmark.realrobot.scanmatch against the simulated lidar of umbmark.model.sensors: noise-free scans
give the true displacement to rounding, noisy ones within the noise (and the covariance says how
much), odometry-sized start errors and, with the coarse stage, a metre and 30 degrees are
recovered, and scenes or inputs that cannot fix a pose say so instead of converging."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from umbmark.errors import InputError
from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
from umbmark.model.se2 import between, compose
from umbmark.model.sensors import Lidar, Room
from umbmark.realrobot.scanmatch import (
    ICPConfig,
    ScanMatches,
    match_consecutive,
    match_scan_pairs,
    match_scans,
)

ROOM = Room.default()
NOISY = Lidar(range_noise_m=0.005)
EXACT = Lidar(range_noise_m=0.0)


def free(points, clearance_m=0.4):
    """Whether every point is inside the room and at least ``clearance_m`` from its walls."""
    xy = np.atleast_2d(np.asarray(points, dtype=float)[..., :2])
    return bool(np.all(ROOM.contains(xy)) and np.all(ROOM.distance_to_walls(xy) >= clearance_m))


def draw_pairs(lidar, k, seed, step_m=0.05, turn_rad=0.12, min_step_m=0.0, min_turn_rad=0.0):
    """``k`` scan pairs from random free poses: displacement up to ``step_m`` / ``turn_rad``.

    Returns (reference scans, current scans, true poses of the current sensor frames in the
    reference ones).
    """
    rng = np.random.default_rng(seed)
    p0, p1 = [], []
    while len(p0) < k:
        a = np.array([rng.uniform(0.5, 9.5), rng.uniform(0.5, 7.5), rng.uniform(-np.pi, np.pi)])
        d = rng.uniform(min_step_m, step_m)
        u = rng.uniform(-np.pi, np.pi)
        turn = rng.choice([-1.0, 1.0]) * rng.uniform(min_turn_rad, turn_rad)
        b = compose(a, [d * math.cos(u), d * math.sin(u), turn])
        if free([a, b]):
            p0.append(a)
            p1.append(b)
    p0, p1 = np.array(p0), np.array(p1)
    return lidar.scan(ROOM, p0, rng), lidar.scan(ROOM, p1, rng), between(p0, p1)


def odometry_guess(truth, seed):
    """The truth with the start errors of uncalibrated odometry: 2 % of the translation, 2 degrees."""
    rng = np.random.default_rng(seed)
    guess = np.array(truth, dtype=float) * [1.02, 1.02, 1.0]
    guess[:, 2] += math.radians(2.0) * rng.choice([-1.0, 1.0], len(guess))
    return guess


def errors(matches, truth):
    """Position [m] and absolute yaw [rad] errors of each match."""
    d = matches.poses - truth
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2])


# ---------------------------------------------------------------- known truth


def test_noise_free_scans_give_the_true_displacement():
    ref, cur, truth = draw_pairs(EXACT, 120, seed=1)
    m = match_scan_pairs(ref, cur, EXACT.angles_rad, odometry_guess(truth, 2))
    pos, yaw = errors(m, truth)
    assert m.converged.all(), set(m.reasons)
    assert pos.max() < 1e-9 and yaw.max() < 1e-9
    assert np.all(m.rms_m < 1e-9)
    assert np.all(m.inlier_fraction > 0.9)


@pytest.mark.parametrize(
    "lidar",
    [
        Lidar(range_noise_m=0.0, fov_rad=math.radians(270.0), n_beams=541),
        Lidar(range_noise_m=0.0, fov_rad=math.radians(180.0), n_beams=181, angle_min_rad=math.radians(100.0)),
        Lidar(range_noise_m=0.0, n_beams=720, angle_min_rad=0.0),
    ],
    ids=["270deg", "rear-180deg", "720-beams-from-0"],
)
def test_noise_free_other_fields_of_view_and_beam_orders(lidar):
    """Partial fields of view (one across the +-pi cut), other beam counts, and the beams reversed."""
    ref, cur, truth = draw_pairs(lidar, 40, seed=3)
    guess = odometry_guess(truth, 4)
    for angles, a, b in ((lidar.angles_rad, ref, cur), (lidar.angles_rad[::-1], ref[:, ::-1], cur[:, ::-1])):
        m = match_scan_pairs(a, b, angles, guess)
        pos, yaw = errors(m, truth)
        ok = m.converged
        assert ok.mean() >= 0.9, set(m.reasons)
        assert pos[ok].max() < 1e-9 and yaw[ok].max() < 1e-9
        # those not converged are scenes a half circle cannot pin down, and say so
        assert all(r.startswith("degenerate scene") for r in np.array(m.reasons)[~ok])


def test_noisy_scans_within_the_noise():
    """360 beams, 5 mm range noise, odometry start errors: about half a millimetre and 0.01 degree."""
    ref, cur, truth = draw_pairs(NOISY, 300, seed=5)
    m = match_scan_pairs(ref, cur, NOISY.angles_rad, odometry_guess(truth, 6))
    pos, yaw = errors(m, truth)
    assert m.converged.all(), set(m.reasons)
    assert np.median(pos) < 1e-3 and np.percentile(pos, 95) < 2.5e-3 and pos.max() < 5e-3
    assert np.degrees(np.median(yaw)) < 0.015 and np.degrees(yaw.max()) < 0.1
    # the residuals are the range noise of both scans (a line averages its points)
    assert 0.004 < np.median(m.rms_m) < 0.0075


def test_covariance_matches_the_errors():
    """Over many pairs the errors' squared Mahalanobis length averages 3 (a chi-square of 3 dof)."""
    ref, cur, truth = draw_pairs(NOISY, 300, seed=7)
    m = match_scan_pairs(ref, cur, NOISY.angles_rad, truth)
    d = m.poses - truth
    m2 = np.einsum("ki,kij,kj->k", d, np.linalg.inv(m.covariances), d)
    assert 0.7 < m2.mean() / 3.0 < 1.4
    # and it is no constant: the per-pair standard deviations differ with the scene
    sd = np.sqrt(m.covariances[:, 0, 0])
    assert sd.max() > 1.5 * sd.min()
    assert np.allclose(m.covariances, np.swapaxes(m.covariances, 1, 2))


def test_dropouts_and_nan():
    """Beams without a return (inf, or nan or 0 as some drivers write) are skipped alike."""
    lidar = Lidar(range_noise_m=0.005, dropout_prob=0.2)
    ref, cur, truth = draw_pairs(lidar, 100, seed=8)
    m = match_scan_pairs(ref, cur, lidar.angles_rad, odometry_guess(truth, 9))
    pos, _ = errors(m, truth)
    assert m.converged.all(), set(m.reasons)
    assert np.median(pos) < 1.5e-3 and pos.max() < 6e-3
    nan_ref, nan_cur = ref.copy(), cur.copy()
    nan_ref[~np.isfinite(ref)] = np.nan
    nan_cur[~np.isfinite(cur)] = np.nan
    m2 = match_scan_pairs(nan_ref, nan_cur, lidar.angles_rad, odometry_guess(truth, 9))
    assert np.array_equal(m2.poses, m.poses)
    nan_cur[np.isnan(nan_cur)] = 0.0  # what some drivers write instead
    m3 = match_scan_pairs(nan_ref, nan_cur, lidar.angles_rad, odometry_guess(truth, 9))
    assert np.array_equal(m3.poses, m.poses)


def test_clutter_only_in_one_scan():
    """Objects that appear between the scans (people walking by) are left out as outliers."""
    rng = np.random.default_rng(10)
    ref, cur, truth, p0 = [], [], [], []
    while len(truth) < 30:
        a = np.array([rng.uniform(2.0, 8.0), rng.uniform(2.0, 6.0), rng.uniform(-np.pi, np.pi)])
        b = compose(a, [0.03, 0.0, 0.05])
        if free([a, b], 0.6):
            p0.append(a)
            truth.append(between(a, b))
            # two 0.4 m boxes 1 to 2 m away, only in the current scan
            boxes = []
            for _ in range(2):
                r, u = rng.uniform(1.0, 2.0), rng.uniform(-np.pi, np.pi)
                cx, cy = b[0] + r * math.cos(u), b[1] + r * math.sin(u)
                c = np.array([[cx - 0.2, cy - 0.2], [cx + 0.2, cy - 0.2], [cx + 0.2, cy + 0.2], [cx - 0.2, cy + 0.2]])
                boxes.append(np.column_stack([c, np.roll(c, -1, axis=0)]))
            cluttered = Room(np.vstack([ROOM.segments] + boxes))
            ref.append(NOISY.scan(ROOM, a, rng))
            cur.append(NOISY.scan(cluttered, b, rng))
    truth = np.array(truth)
    m = match_scan_pairs(np.array(ref), np.array(cur), NOISY.angles_rad, odometry_guess(truth, 11))
    pos, yaw = errors(m, truth)
    assert m.converged.all(), set(m.reasons)
    assert np.median(pos) < 1.5e-3 and pos.max() < 5e-3 and np.degrees(yaw.max()) < 0.1


def test_a_drive_scan_by_scan_from_nominal_odometry():
    """A simulated drive: every consecutive pair from the uncalibrated odometry's guess
    (the sensor pose unknown: the robot's displacement taken for the sensor's)."""
    log = simulate_drive(mixed_program(40.0, seed=3), EXAMPLE_ROBOT, seed=4)
    truth = log.sensor_motion()
    odo = log.odometry()[np.round(log.scan_t_s * log.wheel_rate_hz).astype(int)]
    guess = between(odo[:-1], odo[1:])
    m = match_consecutive(log.ranges_m, log.angles_rad, guess)
    assert len(m) == len(log.ranges_m) - 1
    pos, yaw = errors(m, truth)
    assert m.converged.all(), set(m.reasons)
    assert np.median(pos) < 1e-3 and pos.max() < 5e-3
    assert np.degrees(np.median(yaw)) < 0.015 and np.degrees(yaw.max()) < 0.1
    # the same pairs one by one give the same answers
    one = match_scans(log.ranges_m[5], log.ranges_m[6], log.angles_rad, guess[5])
    assert np.array_equal(one.pose, m.poses[5]) and one.iterations == m.iterations[5]


def corridor_with_doors(length_m=25.0, width_m=2.4):
    """A corridor closed at both ends, with 0.9 m wide, 0.15 m deep door recesses on both walls."""
    walls = [[0.0, 0.0, 0.0, width_m], [length_m, 0.0, length_m, width_m]]
    for y, depth, doors in (
        (0.0, -0.15, (3.1, 7.4, 10.2, 14.9, 18.3, 22.0)),
        (width_m, 0.15, (4.6, 9.0, 13.3, 17.1, 20.6)),
    ):
        x = 0.0
        for d in doors:
            walls += [
                [x, y, d, y],
                [d, y, d, y + depth],
                [d, y + depth, d + 0.9, y + depth],
                [d + 0.9, y + depth, d + 0.9, y],
            ]
            x = d + 0.9
        walls.append([x, y, length_m, y])
    return Room(np.array(walls))


def test_coarse_range_resolution_along_a_corridor_gives_no_short_distances():
    """A 180-beam lidar (1 degree) driven along a corridor, its ranges rounded to 5 cm as some
    logs store them: along a wall the rounded ranges repeat from scan to scan, and lines fitted
    to a few neighbouring points follow their steps, which pulls every match towards no motion
    (lines of five points measured these displacements 15 % short). The lines of whole walls
    measure them within the resolution."""
    room = corridor_with_doors()
    lidar = Lidar(n_beams=180, fov_rad=math.pi, max_range_m=50.0, range_noise_m=0.0)
    t_s = np.arange(300) * 0.16
    poses = np.column_stack([3.0 + 0.35 * t_s, 1.08 + 0.15 * np.sin(0.2 * t_s), 0.05 * np.sin(0.37 * t_s)])
    ranges = lidar.scan(room, poses)
    ranges = np.round((ranges - 0.013) / 0.05) * 0.05 + 0.013  # the same 5 cm grid in every scan
    truth = between(poses[:-1], poses[1:])
    m = match_consecutive(ranges, lidar.angles_rad, truth * [0.985, 0.985, 1.0])
    ok = m.converged
    assert ok.mean() > 0.95, set(m.reasons)
    step = np.hypot(truth[ok, 0], truth[ok, 1])
    measured = np.hypot(m.poses[ok, 0], m.poses[ok, 1])
    assert abs(measured.sum() / step.sum() - 1.0) < 0.01
    assert abs(np.median(measured / step) - 1.0) < 0.02
    _, yaw = errors(m, truth)
    assert np.degrees(np.median(yaw[ok])) < 0.1


def test_large_displacements_need_the_coarse_stage():
    """Up to a metre and 30 degrees from a zero guess: the coarse stage finds every one; ICP alone
    misses some, and never calls a miss converged."""
    ref, cur, truth = draw_pairs(NOISY, 30, seed=12, step_m=1.0, turn_rad=math.radians(30), min_step_m=0.5,
                                 min_turn_rad=math.radians(15))  # fmt: skip
    coarse = match_scan_pairs(ref, cur, NOISY.angles_rad, None, ICPConfig(coarse=True))
    pos, yaw = errors(coarse, truth)
    assert coarse.converged.all(), set(coarse.reasons)
    assert pos.max() < 5e-3 and np.degrees(yaw.max()) < 0.05
    plain = match_scan_pairs(ref, cur, NOISY.angles_rad)
    pos, yaw = errors(plain, truth)
    right = (pos < 5e-3) & (yaw < math.radians(0.05))
    assert not right.all()
    assert np.all(right[plain.converged])
    assert all(plain.reasons[i] for i in np.flatnonzero(~plain.converged))


# ---------------------------------------------------------------- property


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    x=st.floats(1.0, 9.0),
    y=st.floats(1.0, 7.0),
    yaw=st.floats(-math.pi, math.pi),
    dx=st.floats(-0.06, 0.06),
    dy=st.floats(-0.03, 0.03),
    dyaw=st.floats(-0.15, 0.15),
    seed=st.integers(0, 2**32 - 1),
)
def test_matching_both_ways_gives_inverse_poses(x, y, yaw, dx, dy, dyaw, seed):
    a = np.array([x, y, yaw])
    b = compose(a, [dx, dy, dyaw])
    assume(free([a, b], 0.5))
    rng = np.random.default_rng(seed)
    sa, sb = NOISY.scan(ROOM, a, rng), NOISY.scan(ROOM, b, rng)
    ab = match_scans(sa, sb, NOISY.angles_rad)
    ba = match_scans(sb, sa, NOISY.angles_rad)
    assert ab.converged and ba.converged, (ab.reason, ba.reason)
    loop = compose(ab.pose, ba.pose)  # the identity, within the noise of two matches
    assert math.hypot(loop[0], loop[1]) < 4e-3 and abs(loop[2]) < math.radians(0.05)
    assert np.hypot(*(ab.pose[:2] - [dx, dy])) < 4e-3 and abs(ab.pose[2] - dyaw) < math.radians(0.05)


@settings(max_examples=30, deadline=None)
@given(
    x=st.floats(1.0, 9.0),
    y=st.floats(1.0, 7.0),
    yaw=st.floats(-math.pi, math.pi),
    dx=st.floats(-0.08, 0.08),
    dy=st.floats(-0.04, 0.04),
    dyaw=st.floats(-0.2, 0.2),
)
def test_noise_free_property(x, y, yaw, dx, dy, dyaw):
    a = np.array([x, y, yaw])
    b = compose(a, [dx, dy, dyaw])
    assume(free([a, b], 0.5))
    m = match_scans(EXACT.scan(ROOM, a), EXACT.scan(ROOM, b), EXACT.angles_rad)
    assert m.converged, m.reason
    assert np.abs(m.pose - [dx, dy, dyaw]).max() < 1e-9


# ---------------------------------------------------------------- scenes and inputs that fix no pose


def test_corridor_is_degenerate():
    """Two long parallel walls, no end in range: the position along the corridor is free."""
    corridor = Room(np.array([[-50.0, -1.0, 50.0, -1.0], [-50.0, 1.0, 50.0, 1.0]]))
    for lidar, seed in ((EXACT, None), (NOISY, 1)):
        a = np.array([0.0, 0.2, 0.3])
        b = compose(a, [0.05, 0.0, 0.02])
        rng = None if seed is None else np.random.default_rng(seed)
        m = match_scans(lidar.scan(corridor, a, rng), lidar.scan(corridor, b, rng), lidar.angles_rad)
        assert not m.converged
        assert m.reason.startswith("degenerate scene")


def test_no_returns_and_too_few_points():
    ref, cur, truth = draw_pairs(NOISY, 1, seed=13)
    angles = NOISY.angles_rad
    empty = np.full(angles.size, np.inf)
    m = match_scans(empty, cur[0], angles)
    assert not m.converged and m.reason.startswith("too few valid points in the reference scan")
    assert np.isnan(m.covariance).all() and m.iterations == 0
    m = match_scans(ref[0], np.full(angles.size, np.nan), angles)
    assert not m.converged and m.reason.startswith("too few valid points in the current scan")
    sparse = np.full(angles.size, np.inf)
    sparse[:12] = cur[0][:12]
    m = match_scans(ref[0], sparse, angles)
    assert not m.converged and "too few" in m.reason
    # a guess so far off that nothing is within the correspondence distance
    m = match_scans(ref[0], cur[0], angles, (40.0, 0.0, 0.0))
    assert not m.converged and m.reason.startswith("too few correspondences")
    # ranges outside range_min_m .. range_max_m are dropped
    m = match_scans(ref[0], cur[0], angles, config=ICPConfig(range_max_m=0.3))
    assert not m.converged and "too few valid points" in m.reason


@pytest.mark.parametrize(
    "change",
    [
        {"max_iterations": 0},
        {"line_points": 1},
        {"trim_fraction": 1.0},
        {"outlier_sigmas": -1.0},
        {"max_correspondence_m": 0.0},
        {"tolerance_m": float("nan")},
        {"min_inlier_fraction": 1.5},
        {"range_min_m": 5.0, "range_max_m": 1.0},
        {"coarse_range_rad": 4.0},
        {"coarse_candidates": 0},
        {"min_points": 2.5},
    ],
)
def test_config_rejects_bad_settings(change):
    with pytest.raises(InputError) as e:
        ICPConfig(**change)
    assert f"`{next(iter(change))}`" in str(e.value) or "range_min_m" in str(e.value)


def test_input_errors():
    ref, cur, _ = draw_pairs(NOISY, 2, seed=14)
    angles = NOISY.angles_rad
    bent = angles.copy()
    bent[100] += 0.3 * (angles[1] - angles[0])
    with pytest.raises(InputError, match="uniformly spaced"):
        match_scans(ref[0], cur[0], bent)
    with pytest.raises(InputError, match="more than a full turn"):
        match_scans(ref[0], cur[0], np.linspace(0.0, 2.5 * np.pi, angles.size))
    with pytest.raises(InputError, match="one angle per beam"):
        match_scans(ref[0], cur[0], angles[:-1])
    with pytest.raises(InputError, match="equal 1-D"):
        match_scans(ref[0], cur[0][:-1], angles)
    with pytest.raises(InputError, match="initial"):
        match_scans(ref[0], cur[0], angles, (0.0, 0.0))
    with pytest.raises(InputError, match="initial"):
        match_scan_pairs(ref, cur, angles, np.zeros((3, 3)))
    with pytest.raises(InputError, match="finite"):
        match_scans(ref[0], cur[0], angles, (0.0, np.nan, 0.0))
    with pytest.raises(InputError, match="same shape"):
        match_scan_pairs(ref, cur[:1], angles)
    with pytest.raises(InputError, match="config"):
        match_scans(ref[0], cur[0], angles, config={"coarse": True})


def test_results_as_arrays_and_json():
    ref, cur, truth = draw_pairs(NOISY, 3, seed=15)
    ref[1] = np.inf
    m = match_scan_pairs(ref, cur, NOISY.angles_rad, truth)
    assert isinstance(m, ScanMatches) and len(m) == 3
    assert m.poses.shape == (3, 3) and m.covariances.shape == (3, 3, 3)
    assert m.converged.tolist() == [True, False, True]
    assert m.reasons[0] == "" and m.reasons[1]
    assert m[-1].converged and np.array_equal(m[-1].pose, m.poses[2])
    d = json.loads(json.dumps(m.to_dict()))
    assert d["config"]["range_max_m"] is None  # inf is not JSON
    assert d["matches"][0]["x_m"] == pytest.approx(m.poses[0, 0])
    assert d["matches"][1]["converged"] is False
    assert match_consecutive(ref[:1], NOISY.angles_rad).poses.shape == (0, 3)


def test_interpreted_kernels_give_the_compiled_answers():
    """Without numba the same code runs as Python (NUMBA_DISABLE_JIT): the same poses."""
    lidar = Lidar(range_noise_m=0.005, n_beams=90)
    ref, cur, truth = draw_pairs(lidar, 1, seed=16)
    m = match_scans(ref[0], cur[0], lidar.angles_rad, truth[0])
    code = (
        "import json, sys, numpy as np\n"
        "from umbmark.realrobot.scanmatch import match_scans\n"
        "a = json.loads(sys.stdin.read())\n"
        "m = match_scans(np.array(a['ref']), np.array(a['cur']), np.array(a['angles']), a['init'])\n"
        "print(json.dumps([m.pose.tolist(), m.iterations, m.converged]))\n"
    )
    payload = json.dumps(
        {"ref": ref[0].tolist(), "cur": cur[0].tolist(), "angles": lidar.angles_rad.tolist(), "init": truth[0].tolist()}
    ).replace("Infinity", "1e999")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run(
        [sys.executable, "-c", code], input=payload, capture_output=True, text=True, env=env, check=True, timeout=120
    )
    pose, iterations, converged = json.loads(out.stdout)
    assert converged and m.converged and iterations == m.iterations
    assert np.allclose(pose, m.pose, rtol=0, atol=1e-12)


def test_benchmark_script_runs(tmp_path):
    """benchmarks/scan_registration.py on a few pairs into a temporary folder (no timing is asserted)."""
    from conftest import REPO

    out = tmp_path / "bench"
    cmd = [sys.executable, str(REPO / "benchmarks" / "scan_registration.py"), "--duration", "3", "--large", "3"]
    subprocess.run(cmd + ["--numba-cache", "--out", str(out)], capture_output=True, text=True, check=True, timeout=300)
    res = json.loads((out / "scan_registration.json").read_text())
    assert (out / "scan_registration.md").read_text().startswith("# 2D scan registration")
    assert set(res["sets"]) == {"drive, nominal odometry", "drive, 2 % / 2 deg", "large, zero guess"}
    ours = res["sets"]["drive, nominal odometry"]["results"]["umbmark match_consecutive"]
    assert ours["pairs"] == 30 and ours["converged"] == 1.0 and ours["position_mm"]["median"] < 1.0
    assert res["sets"]["large, zero guess"]["results"]["umbmark match_scan_pairs, coarse stage"]["failures"] == 0.0
    assert res["machine"]["cpu_model"] and res["command"].startswith("python ")


def test_kernel_state_says_whether_the_matcher_is_compiled(monkeypatch):
    import umbmark.realrobot.scanmatch_kernel as sm

    lidar = Lidar(range_noise_m=0.005, n_beams=90)
    ref, cur, truth = draw_pairs(lidar, 1, seed=16)
    match_scans(ref[0], cur[0], lidar.angles_rad, truth[0])
    assert sm.kernel_state() == "ready"  # compiled in this process (or loaded from numba's cache)
    monkeypatch.setattr(sm, "numba_module", lambda: None)
    assert sm.kernel_state() == "interpreted"


@pytest.mark.parametrize(
    "state, terminal, said",
    [
        ("interpreted", False, "warning: numba is not installed"),
        ("compile", True, "compiling the scan matcher (once per machine"),
        ("compile", False, ""),
        ("ready", True, ""),
    ],
)
def test_selfcal_says_when_the_matching_will_be_slow(monkeypatch, capsys, state, terminal, said):
    import umbmark.cli.progress as progress
    import umbmark.realrobot.scanmatch as sm
    from umbmark.cli.bags import start_kernels

    started = []
    monkeypatch.setattr(sm, "kernel_state", lambda: state)
    monkeypatch.setattr(sm, "start_compiling", lambda: started.append(True))
    monkeypatch.setattr(progress, "progress_enabled", lambda console=None: terminal)
    start_kernels()
    err = capsys.readouterr().err
    assert (said in err) if said else err == ""
    assert len(err.splitlines()) <= 1
    assert started == ([True] if state == "compile" else [])  # the compile starts before the bags are read


@pytest.mark.slow
def test_a_machine_without_the_kernels_compiles_them_in_two_processes(tmp_path):
    """An empty numba cache: kernel_state says "compile"; start_compiling's second process writes
    the matching kernels into the cache (the first match waits for them and loads them); the
    answers are the ones compiled here; afterwards "ready"."""
    lidar = Lidar(range_noise_m=0.005, n_beams=90)
    ref, cur, truth = draw_pairs(lidar, 2, seed=16)
    m = match_scan_pairs(ref, cur, lidar.angles_rad, truth)
    code = (
        "import json, sys, numpy as np\n"
        "from umbmark.realrobot import scanmatch_kernel as k, scanmatch as sm\n"
        "a = json.loads(sys.stdin.read())\n"
        "before = sm.kernel_state()\n"
        "sm.start_compiling()\n"
        "helper = k._helper[0]\n"
        "m = sm.match_scan_pairs(np.array(a['ref']), np.array(a['cur']), np.array(a['angles']), np.array(a['init']))\n"
        "print(json.dumps([before, helper.returncode, sm.kernel_state(), m.poses.tolist(), m.iterations.tolist()]))\n"
    )
    payload = json.dumps(
        {"ref": ref.tolist(), "cur": cur.tolist(), "angles": lidar.angles_rad.tolist(), "init": truth.tolist()}
    ).replace("Infinity", "1e999")
    cache = tmp_path / "numba-cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run(
        [sys.executable, "-c", code], input=payload, capture_output=True, text=True, env=env, check=True, timeout=300
    )
    before, helper_rc, after, poses, iterations = json.loads(out.stdout)
    assert (before, helper_rc, after) == ("compile", 0, "ready")
    written = {p.name.split("-")[0] for p in cache.rglob("*.nbi")}
    kernels = ("_icp", "_prepare_scan", "_prepare_kernel", "_pairs_kernel")
    assert {f"scanmatch_kernel.{k}" for k in kernels} <= written
    assert np.allclose(poses, m.poses, rtol=0, atol=1e-12) and iterations == m.iterations.tolist()
