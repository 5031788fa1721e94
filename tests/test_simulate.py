import math

import numpy as np
import pytest

from umbmark.errors import InputError
from umbmark.metrics import umbmark_figures
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, OdometryParams
from umbmark.model.simulate import (
    MAX_SAMPLES_PER_RUN,
    NOISE_PRESETS,
    Motion,
    NoiseModel,
    Segment,
    per_run_params,
    plan_program,
    run_program,
    run_seeds,
    simulate_runs,
    simulate_umbmark,
    spin_program,
    square_program,
    straight_program,
)

NOMINAL = OdometryParams.from_geometry(LABMATE)
EXACT = Motion(sample_period_s=None)


def drive(program, errors, model=NOMINAL, motion=EXACT, **kw):
    return run_program(program, errors.true_params(LABMATE), model, 1, motion=motion, **kw)


def test_bigger_right_wheel_curves_left_while_odometry_says_straight():
    r = drive(straight_program(4.0), ErrorParams(ed=1.002))
    assert r.true_y[0] > 0.01 and r.true_theta[0] > 0  # curved to the left
    assert r.odo_y[0] == pytest.approx(0, abs=1e-12) and r.odo_x[0] == pytest.approx(4.0, abs=1e-12)
    r = drive(straight_program(4.0), ErrorParams(ed=0.998))
    assert r.true_y[0] < -0.01


def test_smaller_wheelbase_turns_more_than_commanded():
    r = drive(spin_program(math.pi / 2), ErrorParams(eb=0.98))
    assert r.odo_theta[0] == pytest.approx(math.pi / 2, abs=1e-12)
    assert r.true_theta[0] == pytest.approx(math.pi / 2 / 0.98, rel=1e-12)


@pytest.mark.parametrize("ed", [0.99, 1.0, 1.01])
def test_turn_angle_depends_on_average_diameter_only(ed):
    # Eq. 2.15: actual turn / nominal turn = D_avg / D_n, whatever E_d is
    r = drive(spin_program(math.pi / 2), ErrorParams(ed=ed, es=1.01))
    assert r.true_theta[0] == pytest.approx(math.pi / 2 * 1.01, rel=1e-12)
    shift = math.hypot(r.true_x[0], r.true_y[0])
    if ed == 1.0:
        assert shift == pytest.approx(0, abs=1e-12)
    else:
        # unequal wheels: the turn centre is off the axle midpoint, the robot is displaced
        assert shift > 1e-4


def test_closed_loop_odometry_returns_to_start_while_true_pose_drifts():
    for d in ("cw", "ccw"):
        r = simulate_runs(d, 1, ErrorParams(ed=1.001, eb=0.99), motion=EXACT)
        assert abs(r.odo_x[0]) < 1e-9 and abs(r.odo_y[0]) < 1e-9
        assert abs(math.remainder(r.odo_theta[0], 2 * math.pi)) < 1e-9
        assert math.hypot(r.true_x[0], r.true_y[0]) > 0.02


def test_turn_direction_of_programs():
    assert [s.amount for s in square_program("cw", 4.0) if s.kind == "turn"] == [-math.pi / 2] * 4
    assert [s.amount for s in square_program("ccw", 4.0) if s.kind == "turn"] == [math.pi / 2] * 4
    r = run_program(square_program("cw", 4.0)[:2], NOMINAL, NOMINAL, motion=EXACT, trajectory=True)
    assert r.true_theta[0] == pytest.approx(-math.pi / 2)  # cw: turn to the right
    with pytest.raises(InputError):
        square_program("left", 4.0)


def test_sampled_stops_are_exact_without_noise():
    e = ErrorParams(ed=1.003, eb=0.985)
    a = simulate_umbmark(e, n_runs=1, motion=EXACT)
    b = simulate_umbmark(e, n_runs=1, motion=Motion(sample_period_s=0.01))
    c = simulate_umbmark(e, n_runs=1, motion=Motion(sample_period_s=0.037))  # not a divisor of the legs
    for other in (b, c):
        np.testing.assert_allclose(other.x_abs, a.x_abs, atol=1e-9)
        np.testing.assert_allclose(other.y_abs, a.y_abs, atol=1e-9)


def test_paper_check_value():
    """Fig. 11 robot, noise-free: uncalibrated E_max,syst about 311 mm (reference sheet)."""
    runs = simulate_umbmark(ErrorParams(ed=1.00084, eb=336.17 / 340), n_runs=5, noise="none")
    assert umbmark_figures(runs).emax_syst * 1e3 == pytest.approx(311, rel=0.03)


def test_calibration_with_true_parameters_removes_the_error():
    e = ErrorParams(ed=1.004, eb=0.97)
    runs = simulate_umbmark(e, n_runs=1, motion=EXACT, calibration=e.ideal_calibration(LABMATE))
    assert umbmark_figures(runs).emax_syst < 1e-9


def test_noise_is_seeded_and_reproducible():
    e = ErrorParams(ed=1.001)
    a = simulate_umbmark(e, n_runs=3, noise="paper", seed=5)
    b = simulate_umbmark(e, n_runs=3, noise="paper", seed=5)
    c = simulate_umbmark(e, n_runs=3, noise="paper", seed=6)
    np.testing.assert_array_equal(a.x_abs, b.x_abs)
    assert not np.array_equal(a.x_abs, c.x_abs)


def test_a_seed_object_gives_the_same_runs_every_time():
    """SeedSequence.spawn counts its calls; the simulator must not: passing one seed object twice
    (a benchmark's common random numbers) gives the same runs, equal to the integer seed's."""
    e = ErrorParams(ed=1.001)
    ss = np.random.SeedSequence(5)
    a = simulate_umbmark(e, n_runs=3, noise="paper", seed=ss)
    b = simulate_umbmark(e, n_runs=3, noise="paper", seed=ss)
    c = simulate_umbmark(e, n_runs=3, noise="paper", seed=5)
    np.testing.assert_array_equal(a.x_abs, b.x_abs)
    np.testing.assert_array_equal(a.x_abs, c.x_abs)
    assert ss.n_children_spawned == 0


def test_a_run_does_not_depend_on_its_batch():
    noise = NOISE_PRESETS["paper"]
    prog = square_program("ccw", 4.0)
    true = ErrorParams(ed=1.001).true_params(LABMATE)
    rngs = run_seeds(42, 4)
    batch = run_program(prog, true, NOMINAL, 4, noise, rngs=rngs)
    alone = run_program(prog, true, NOMINAL, 1, noise, rngs=[run_seeds(42, 4)[2]])
    assert batch.abs_x[2] == alone.abs_x[0] and batch.abs_y[2] == alone.abs_y[0]


def test_robots_can_differ_within_a_batch():
    eds = np.array([0.999, 1.0, 1.002])
    ps = [ErrorParams(ed=e).true_params(LABMATE) for e in eds]
    per = {k: np.array([getattr(p, k) for p in ps]) for k in ("left_m_per_pulse", "right_m_per_pulse", "wheelbase_m")}
    batch = run_program(straight_program(2.0), None, NOMINAL, 3, motion=EXACT, true_per_run=per)
    for i, p in enumerate(ps):
        one = run_program(straight_program(2.0), p, NOMINAL, 1, motion=EXACT)
        assert batch.true_y[i] == pytest.approx(one.true_y[0], abs=1e-15)


def test_quantised_encoders_stop_within_one_sample():
    noise = NoiseModel(quantise=True)
    motion = Motion(sample_period_s=0.01)
    r = run_program(straight_program(1.0), NOMINAL, NOMINAL, 5, noise, motion, rngs=run_seeds(1, 5))
    overshoot = r.odo_x - 1.0
    assert np.all(overshoot >= -1e-12)
    assert np.all(overshoot <= 0.2 * 0.01 + 2 * LABMATE.m_per_pulse)
    # the true robot went as far as its wheels turned: within a pulse of the odometry
    assert np.all(np.abs(r.true_x - r.odo_x) <= 2 * LABMATE.m_per_pulse)


@pytest.mark.slow
def test_paper_noise_preset_spread_is_about_25_mm():
    runs = simulate_umbmark(ErrorParams(ed=1.00084, eb=336.17 / 340), n_runs=200, noise="paper", seed=3)
    res = umbmark_figures(runs)
    for st in (res.cw, res.ccw):
        assert 20e-3 < st.std < 30e-3


def test_noise_requires_sampling_and_generators():
    with pytest.raises(InputError):
        run_program(straight_program(1.0), NOMINAL, NOMINAL, 1, NOISE_PRESETS["paper"], EXACT, rngs=run_seeds(0, 1))
    with pytest.raises(InputError):
        run_program(straight_program(1.0), NOMINAL, NOMINAL, 2, NOISE_PRESETS["paper"])


def test_calibration_is_loaded_into_the_controller():
    """A calibrated robot drives straight: the controller commands equal corrected travel."""
    e = ErrorParams(ed=1.01)
    cal = e.ideal_calibration(LABMATE)
    model = OdometryParams.from_geometry(LABMATE, Calibration(cal.c_left, cal.c_right, LABMATE.wheelbase_m))
    r = drive(straight_program(4.0), e, model=model)
    assert abs(r.true_y[0]) < 1e-12 and r.true_x[0] == pytest.approx(4.0, abs=1e-12)


def test_plan_of_a_sampled_program():
    """0.3 m at 0.2 m/s and 7 ms: 214 full samples and a last one of 2/7 step; a quarter turn on a
    0.34 m wheelbase needs pi/2 * 0.17 m of opposite travel per wheel."""
    prog = (Segment("straight", 0.3), Segment("turn", -math.pi / 2))
    m = np.full(2, NOMINAL.left_m_per_pulse)
    b = np.array([0.34, 0.30])
    plan = plan_program(prog, Motion(sample_period_s=0.007), NOISE_PRESETS["none"], m, m, b)
    np.testing.assert_array_equal(plan.kind, [0, 1])
    np.testing.assert_array_equal(plan.sign_left, [1.0, 1.0])
    np.testing.assert_array_equal(plan.sign_right, [1.0, -1.0])
    np.testing.assert_array_equal(plan.target, [0.3, math.pi / 2])
    step = 0.2 * 0.007
    assert plan.step.shape == (2, 2) and np.all(plan.step == step)
    np.testing.assert_array_equal(plan.n_full[:, 0], [214, 214])
    assert plan.frac[0, 0] == pytest.approx(0.3 / step - 214)
    need = math.pi / 2 * b / 2
    np.testing.assert_array_equal(plan.n_full[:, 1], np.floor(need / step))
    np.testing.assert_allclose(plan.frac[:, 1], need / step - np.floor(need / step))
    np.testing.assert_array_equal(plan.samples, plan.n_full + (plan.frac > 0))


def test_plan_without_sampling_is_one_step_per_segment():
    m = np.array([NOMINAL.left_m_per_pulse])
    plan = plan_program(square_program("ccw", 2.0), EXACT, NOISE_PRESETS["none"], m, m, np.array([0.34]))
    np.testing.assert_array_equal(plan.samples, np.ones((1, 8)))
    np.testing.assert_array_equal(plan.frac, np.ones((1, 8)))
    np.testing.assert_allclose(plan.step[0], [2.0, math.pi / 2 * 0.17] * 4)


def test_plan_whole_and_nearly_whole_step_counts():
    """A ratio within 1e-12 below a whole number counts as whole; a leftover below 1e-9 step is dropped."""
    m = np.array([1e-4])
    motion = Motion(speed_m_s=0.1, sample_period_s=0.01)
    step = 0.1 * 0.01
    for length in (500 * step, (500 - 5e-13) * step, (500 + 5e-10) * step):
        plan = plan_program((Segment("straight", length),), motion, NOISE_PRESETS["none"], m, m, np.array([0.3]))
        assert plan.n_full[0, 0] == 500 and plan.frac[0, 0] == 0.0 and plan.samples[0, 0] == 500
    plan = plan_program((Segment("straight", 500.5 * step),), motion, NOISE_PRESETS["none"], m, m, np.array([0.3]))
    assert plan.n_full[0, 0] == 500 and plan.frac[0, 0] == pytest.approx(0.5) and plan.samples[0, 0] == 501


def test_plan_reserves_a_margin_for_quantised_encoders():
    m = np.array([4.7e-5])
    motion = Motion(sample_period_s=0.01)
    plain = plan_program(straight_program(1.0), motion, NOISE_PRESETS["none"], m, m, np.array([0.34]))
    quant = plan_program(straight_program(1.0), motion, NoiseModel(quantise=True), m, m, np.array([0.34]))
    # one pulse of lag per wheel is under one sample (4.7e-5 m of the 2e-3 m step): 1 + 2 spare samples
    np.testing.assert_array_equal(quant.samples - plain.samples, [[3]])


def test_plan_refuses_absurd_sample_counts():
    m = np.array([4.7e-5])
    long = straight_program(MAX_SAMPLES_PER_RUN * 0.2 * 0.01 * 1.01)
    with pytest.raises(InputError, match="samples"):
        plan_program(long, Motion(), NOISE_PRESETS["none"], m, m, np.array([0.34]))


def test_per_run_params_broadcast_and_check():
    t_l, t_r, t_b = per_run_params({"wheelbase_m": [0.3, 0.4]}, NOMINAL, 2, "true")
    np.testing.assert_array_equal(t_b, [0.3, 0.4])
    np.testing.assert_array_equal(t_l, [NOMINAL.left_m_per_pulse] * 2)
    with pytest.raises(InputError, match="model robot parameter left_m_per_pulse is missing"):
        per_run_params({"wheelbase_m": 0.3}, None, 2, "model")
    with pytest.raises(InputError, match="true robot parameters must be positive"):
        per_run_params({"wheelbase_m": [0.3, -0.4]}, NOMINAL, 2, "true")
