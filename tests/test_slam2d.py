"""The self-calibration study against ground-truth relations (umbmark.studies.slam2d).

Known truth first: a simulated robot (wheels 1 % apart, wheelbase 3 % off, lidar 120 mm ahead,
30 mm right, turned 2 deg, noise-free scans) written as a ROS 1 bag with its nominal /odom, and
relations made from its true laser poses: the calibrated odometry matches them to micrometres
and the nominal odometry's systematic errors are those its geometry predicts; scans stamped
late by a known delay are found out. Then a slice of the real MIT CSAIL log (data/slam2d): what
must hold whatever the robot, e.g. which results do not depend on the assumed nominal geometry.
"""

import dataclasses
import math

import numpy as np
import pytest
from conftest import REPO
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")
from umbmark.errors import InputError  # noqa: E402
from umbmark.io.relations import Relations, read_relations, write_relations  # noqa: E402
from umbmark.io.rosbag import read_selfcal_bag  # noqa: E402
from umbmark.io.rosbag_write import EPOCH_S, write_drive_bag  # noqa: E402
from umbmark.io.wheels import WheelSource  # noqa: E402
from umbmark.jsonutil import dumps  # noqa: E402
from umbmark.model import se2  # noqa: E402
from umbmark.model.drive import SimRobot, mixed_program, simulate_drive  # noqa: E402
from umbmark.model.geometry import (  # noqa: E402
    LABMATE,
    ErrorParams,
    WheelGeometry,  # noqa: E402
)
from umbmark.model.sensors import Lidar, SensorPose  # noqa: E402
from umbmark.realrobot.selfcal import (  # noqa: E402
    IntervalOptions,
    KeyframeRule,
    estimate_scan_delay,
    match_intervals,
    plan_intervals,
)
from umbmark.realrobot.wheels import scan_wheel_angles  # noqa: E402
from umbmark.studies.slam2d import (  # noqa: E402
    ErrorStats,
    SystematicErrors,
    in_sensor_frame,
    odometry_from_wheels,
    recorded_odometry_at_scans,
    relation_errors,
    study_log,
)

DATA = REPO / "data" / "slam2d"
ROBOT = SimRobot(
    nominal=LABMATE,
    errors=ErrorParams(ed=1.01, eb=1.03, es=0.99),
    sensor_pose=SensorPose(0.120, -0.030, math.radians(2.0)),
    lidar=Lidar(n_beams=360, range_noise_m=0.0),
)
D_NOM, B_NOM = LABMATE.wheel_diameter_m, LABMATE.wheelbase_m
DELAY_S = 0.05

# ---------------------------------------------------------------------------------------------
# the metric and the fits

pose = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-3.1, 3.1))


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(pose, pose), min_size=1, max_size=20))
def test_relation_errors_are_the_composed_difference(pairs):
    ref = np.array([p for p, _ in pairs])
    delta = np.array([d for _, d in pairs])
    pred = se2.compose(ref, delta)
    t, r = relation_errors(pred, ref)
    assert np.allclose(t, np.hypot(delta[:, 0], delta[:, 1]), atol=1e-9)
    assert np.allclose(r, np.abs(delta[:, 2]), atol=1e-9)
    t0, r0 = relation_errors(ref, ref)
    assert np.all(t0 < 1e-12) and np.all(r0 < 1e-12)


def test_relation_errors_wrap_the_angle_and_check_shapes():
    t, r = relation_errors([[0, 0, math.pi - 0.01]], [[0, 0, -math.pi + 0.01]])
    assert r[0] == pytest.approx(0.02) and t[0] == 0
    with pytest.raises(InputError, match=r"\(K, 3\)"):
        relation_errors(np.zeros((2, 3)), np.zeros((3, 3)))


def test_error_stats_in_the_benchmarks_units():
    s = ErrorStats.from_errors([0.1, 0.3], np.radians([1.0, 3.0]))
    assert s.count == 2
    assert s.mae_translation_m == pytest.approx(0.2)
    assert s.mse_translation_m2 == pytest.approx(0.05)
    assert s.sd_translation_m == pytest.approx(math.sqrt(0.02))
    d = s.to_dict()
    assert d["rotation"]["mae_deg"] == pytest.approx(2.0)
    assert d["rotation"]["mse_deg2"] == pytest.approx(5.0)
    assert d["translation"]["mse_m2"] == pytest.approx(0.05)
    empty = ErrorStats.from_errors([], [])
    assert empty.count == 0 and math.isnan(empty.mae_translation_m)
    assert '"mae_m": null' in dumps(empty.to_dict())


@settings(max_examples=60, deadline=None)
@given(
    st.floats(0.8, 1.2),
    st.floats(0.8, 1.2),
    st.floats(-0.05, 0.05),
    st.integers(0, 2**32 - 1),
)
def test_systematic_errors_recover_a_scale_a_turn_and_a_drift(scale, turn, drift, seed):
    rng = np.random.default_rng(seed)
    ref = np.column_stack([rng.uniform(-0.2, 1.0, 40), rng.uniform(-0.3, 0.3, 40), rng.uniform(-0.5, 0.5, 40)])
    pred = np.column_stack([scale * ref[:, :2], turn * ref[:, 2] + drift * ref[:, 0]])
    s = SystematicErrors.fit(pred, ref)
    assert s.count == 40
    assert s.distance_scale == pytest.approx(scale, abs=1e-9)
    assert s.turn_scale == pytest.approx(turn, abs=1e-9)
    assert s.drift_rad_per_m == pytest.approx(drift, abs=1e-9)
    lo, hi = s.turn_scale_ci95
    assert lo - 1e-9 <= turn <= hi + 1e-9


def test_systematic_errors_of_too_few_relations_are_nan():
    s = SystematicErrors.fit(np.zeros((2, 3)), np.ones((2, 3)))
    assert math.isnan(s.distance_scale) and s.count == 2
    assert dumps(s.to_dict())


def test_in_sensor_frame():
    q = np.array([[0.0, 0.0, math.pi / 2], [1.0, 0.0, 0.0]])
    assert np.allclose(in_sensor_frame(q, (0, 0, 0)), q)
    s = in_sensor_frame(q, (0.1, 0.0, 0.0))
    # a spin moves a lidar 0.1 m ahead of the axle along the chord of its circle
    assert math.hypot(s[0, 0], s[0, 1]) == pytest.approx(2 * 0.1 * math.sin(math.pi / 4))
    assert s[0, 2] == pytest.approx(math.pi / 2)
    assert np.allclose(in_sensor_frame(q, (0.0, 0.0, math.pi))[1], [-1.0, 0.0, 0.0])


# ---------------------------------------------------------------------------------------------
# known truth: a simulated drive


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    log = simulate_drive(mixed_program(80.0, seed=11, robot=ROBOT), ROBOT, seed=12)
    root = tmp_path_factory.mktemp("slam2d_sim")
    world = log.sensor_world_pose
    m = len(log.scan_t_s)
    rng = np.random.default_rng(3)
    a = np.arange(0, m - 5, 2)
    b = a + rng.integers(1, 5, a.size)
    la = rng.integers(0, m // 2, 10)  # long relations, across the halves
    a, b = np.concatenate([a, la]), np.concatenate([b, la + m // 2 - 5])

    def write(lg, name, delay_s):
        bag = write_drive_bag(lg, root / f"{name}.bag", storage="ros1", odom=True)
        stamps = EPOCH_S + lg.scan_t_s
        write_relations(Relations(stamps[a], stamps[b], se2.between(world[a], world[b])), root / f"{name}.relations")
        return bag, root / f"{name}.relations"

    late = dataclasses.replace(log, scan_t_s=log.scan_t_s + DELAY_S)  # scans stamped late
    return {"log": log, "on time": write(log, "sim", 0.0), "late": write(late, "late", DELAY_S)}


@pytest.fixture(scope="module")
def sim_study(sim):
    return study_log(*sim["on time"], D_NOM, B_NOM, scan_delay_s="estimate")


def test_simulated_calibrations_recover_the_true_geometry(sim, sim_study):
    log = sim["log"]
    true = log.true_geometry
    sp = log.sensor_pose
    for c in sim_study.calibrations:
        r = c.report.result
        assert r.r_left_m == pytest.approx(true.diameter_left_m / 2, rel=1e-5), c.label
        assert r.r_right_m == pytest.approx(true.diameter_right_m / 2, rel=1e-5)
        assert r.wheelbase_m == pytest.approx(true.wheelbase_m, rel=1e-5)
        assert np.allclose(r.sensor_pose, (sp.x_m, sp.y_m, sp.yaw_rad), atol=1e-4)
        assert abs(c.scan_delay.delay_s) < 2e-3 and c.scan_delay.correlation > 0.9999
    assert sim_study.scan_delay_mode == "estimated"
    assert [c.label for c in sim_study.calibrations] == ["first half", "second half", "full log"]


def test_simulated_after_matches_the_truth_and_before_has_the_predicted_errors(sim, sim_study):
    """Out of sample: each half's odometry calibrated on the other half matches the relations to
    micrometres; the nominal odometry's distance scale, turn scale and drift are those of its
    nominal geometry against the true one."""
    true = sim["log"].true_geometry
    r_nom, rl, rr = D_NOM / 2, true.diameter_left_m / 2, true.diameter_right_m / 2
    scale = r_nom / (0.5 * (rl + rr))  # nominal travel per true travel
    turn = scale * true.wheelbase_m / B_NOM
    drift = r_nom * (1 / rr - 1 / rl) / B_NOM  # heading per metre driven straight
    for label in ("first half", "second half"):
        t = sim_study.test(label)
        assert t.relations_short > 150 and t.calibrated_on != label
        after, before = t.after, t.before
        assert after.calibration == t.calibrated_on and after.sensor_pose_source == "estimated"
        assert after.short.mae_translation_m < 1e-5 and after.short.mae_rotation_rad < 1e-5
        assert after.systematic.distance_scale == pytest.approx(1.0, abs=1e-4)
        assert after.systematic.turn_scale == pytest.approx(1.0, abs=1e-4)
        assert before.short.mae_translation_m > 30 * after.short.mae_translation_m
        assert before.systematic.distance_scale == pytest.approx(scale, abs=2e-3)
        assert before.systematic.turn_scale == pytest.approx(turn, abs=2e-3)
        assert before.systematic.drift_rad_per_m == pytest.approx(drift, abs=1e-3)
        # /odom is the nominal odometry: recomputed from the wheel travel it is the same (to the
        # difference between arcs and the recorded poses interpolated linearly between samples)
        rec = t.get("recorded@/tf_static")
        assert rec.short.mae_translation_m == pytest.approx(before.short.mae_translation_m, rel=1e-3)
    full = sim_study.test("full log")
    assert full.relations_long == 10 and sim_study.relations_crossing == 10
    assert full.after.long.mae_translation_m < 1e-3 < full.before.long.mae_translation_m
    check = sim_study.scan_matching
    assert check.converged == check.relations and check.matcher.mae_translation_m < 1e-5


def test_simulated_late_scans_are_found_and_corrected(sim):
    bag = read_selfcal_bag(sim["late"][0], wheels=WheelSource(odom_topic="/odom"))
    d = estimate_scan_delay(
        match_intervals(plan_intervals(bag, D_NOM, B_NOM, IntervalOptions(keyframes=KeyframeRule()))), D_NOM, B_NOM
    )
    assert d.delay_s == pytest.approx(DELAY_S, abs=2e-3)
    assert d.correlation > 0.9999 > d.correlation_at_zero
    fixed = study_log(*sim["late"], D_NOM, B_NOM, scan_delay_s="estimate")
    as_recorded = study_log(*sim["late"], D_NOM, B_NOM)
    given_delay = study_log(*sim["late"], D_NOM, B_NOM, scan_delay_s=DELAY_S)
    assert as_recorded.scan_delay_mode == "recorded" and given_delay.scan_delay_mode == "given"
    for label in ("first half", "second half"):
        good, bad = fixed.test(label), as_recorded.test(label)
        assert good.scan_delay_s == pytest.approx(DELAY_S, abs=2e-3) and bad.scan_delay_s == 0
        assert good.after.short.mae_translation_m < 1e-4
        assert bad.after.short.mae_translation_m > 10 * good.after.short.mae_translation_m
        assert given_delay.test(label).after.short.mae_translation_m < 1e-4


def test_study_to_dict_is_strict_json(sim_study):
    d = sim_study.to_dict()
    text = dumps(d)
    assert "NaN" not in text
    cal = d["calibrations"][0]
    for key in ("wheel_diameter_left_mm", "Ed", "Eb", "Eb_ci95", "sensor_pose", "intervals_used", "warnings"):
        assert key in cal
    assert isinstance(cal["intervals_rejected"], int) and "covariance" not in cal
    assert set(cal["turn_regression"]) == {"sensor_on_wheels", "inverse_wheels_on_sensor", "correlation"}
    test = d["tests"][0]
    assert test["before"] == "nominal@/tf_static" and test["after"] == "calibrated(first half)@estimated"
    ev = test["evaluations"][0]
    assert set(ev) >= {"key", "all", "short", "long", "systematic", "sensor_pose"}
    assert set(ev["short"]["translation"]) == {"mae_m", "mae_sd_m", "mse_m2", "mse_sd_m2"}
    assert d["nominal"] == {"wheel_diameter_mm": D_NOM * 1e3, "wheelbase_mm": pytest.approx(B_NOM * 1e3)}


def test_bad_arguments(sim):
    bag, rel = sim["on time"]
    with pytest.raises(InputError, match="short_max_s"):
        study_log(bag, rel, D_NOM, B_NOM, short_max_s=0)
    with pytest.raises(InputError, match="scan_delay_s"):
        study_log(bag, rel, D_NOM, B_NOM, scan_delay_s="guess")
    with pytest.raises(InputError, match="window_s"):
        study_log(bag, rel, D_NOM, B_NOM, window_s=(10.0, 5.0))
    with pytest.raises(InputError, match="too few to study"):
        study_log(bag, rel, D_NOM, B_NOM, window_s=(0.0, 1.0))
    with pytest.raises(InputError, match="are these the relations of this log"):
        study_log(bag, DATA / "aces.relations", D_NOM, B_NOM)


# ---------------------------------------------------------------------------------------------
# a slice of a real log: MIT CSAIL, the first 160 s

WINDOW = (0.0, 160.0)
MIT = (DATA / "mit-csail.bag", DATA / "mit-csail.relations")


@pytest.fixture(scope="module")
def mit():
    return {
        (d, b): study_log(*MIT, d, b, window_s=WINDOW, scan_delay_s="estimate") for d, b in ((0.20, 0.40), (0.15, 0.30))
    }


def test_recomputed_odometry_keeps_the_recorded_heading():
    """The wheel travel made from /odom through any nominal geometry gives back its heading
    exactly (the positions up to the increments' sideways parts, which no arc has)."""
    bag = read_selfcal_bag(MIT[0], wheels=WheelSource(odom_topic="/odom"))
    rec = recorded_odometry_at_scans(bag)
    for d, b in ((0.2, 0.4), (0.15, 0.3)):
        left, right = scan_wheel_angles(bag, WheelGeometry(d, d, b))
        odo = odometry_from_wheels(left, right, d / 2, d / 2, b)
        dyaw = np.diff(odo[:, 2]) - np.diff(rec[:, 2])
        assert np.abs(dyaw).max() < 1e-9
        step_rec = se2.between(rec[:-1], rec[1:])
        step_odo = se2.between(odo[:-1], odo[1:])
        gap = np.hypot(*(step_rec[:, :2] - step_odo[:, :2]).T)
        assert np.median(gap) < 5e-3 and np.all(gap <= np.hypot(step_rec[:, 0], step_rec[:, 1]) + 1e-9)


@pytest.mark.slow
def test_real_slice_results_that_do_not_depend_on_the_nominal_geometry(mit):
    """c_left, c_right (estimated over nominal diameter), E_b, the lidar pose, the scan delay and
    every odometry's error against the relations are the same for either nominal geometry; the
    diameters and wheelbase in mm scale with it, and E_d - 1 with the nominal wheelbase (the data
    fix the heading drift per metre, (E_d - 1) / b)."""
    a, b = mit[(0.20, 0.40)], mit[(0.15, 0.30)]
    for ca, cb in zip(a.calibrations, b.calibrations):
        ra, rb = ca.report, cb.report
        assert ca.scan_delay_s == pytest.approx(cb.scan_delay_s, abs=1e-9)
        assert ra.c_left == pytest.approx(rb.c_left, rel=2e-3)
        assert ra.c_right == pytest.approx(rb.c_right, rel=2e-3)
        assert ra.result.eb == pytest.approx(rb.result.eb, rel=2e-3)
        assert np.allclose(ra.result.sensor_pose, rb.result.sensor_pose, atol=2e-3)
        assert ra.result.wheelbase_m / rb.result.wheelbase_m == pytest.approx(0.40 / 0.30, rel=2e-3)
        assert ra.result.diameter_left_m / rb.result.diameter_left_m == pytest.approx(0.20 / 0.15, rel=2e-3)
        ratio = (ra.result.ed - 1) / (rb.result.ed - 1)
        assert ratio == pytest.approx(0.40 / 0.30, rel=0.1)
    for ta, tb in zip(a.tests, b.tests):
        for ea, eb in zip(ta.evaluations, tb.evaluations):
            assert ea.key == eb.key
            assert ea.short.mse_translation_m2 == pytest.approx(eb.short.mse_translation_m2, rel=1e-2)
            assert ea.short.mse_rotation_rad2 == pytest.approx(eb.short.mse_rotation_rad2, rel=1e-2)
            if ea.odometry != "calibrated" and ea.sensor_pose_source == "/tf_static":
                assert ea.short.mse_translation_m2 == pytest.approx(eb.short.mse_translation_m2, rel=1e-9)


def test_real_slice_study_is_consistent(mit):
    s = mit[(0.20, 0.40)]
    assert s.t_end_s <= WINDOW[1] and s.scans > 500
    rel = read_relations(MIT[1])
    first = s.test("first half")
    second = s.test("second half")
    full = s.test("full log")
    assert first.relations_short + first.relations_long + second.relations_short + second.relations_long + (
        s.relations_crossing
    ) == (full.relations_short + full.relations_long)
    assert full.relations_short + full.relations_long < len(rel)
    # the halves' tests read the odometry with the delay found on the half that calibrated
    assert first.scan_delay_s == s.calibration("second half").scan_delay_s
    # the scans lag the odometry by about a tenth of a second in this log (found on the full log too)
    for c in s.calibrations:
        assert 0.05 < c.scan_delay_s < 0.15
        assert c.scan_delay.correlation > c.scan_delay.correlation_at_zero
    # the matcher measures the laser's turns far better than the odometry (which the relations judge)
    check = s.scan_matching
    assert check.converged > 0.6 * check.relations
    assert check.matcher.mae_rotation_rad < 0.5 * check.odometry.mae_rotation_rad
