"""umbmark.studies.reference: the per-sample loops agree with the vectorised code they are the oracle of."""

import math

import numpy as np
import pytest

from umbmark.errors import InputError
from umbmark.metrics import umbmark_figures
from umbmark.model import odometry, simulate
from umbmark.model.geometry import LABMATE, ErrorParams, OdometryParams
from umbmark.model.simulate import Motion, NoiseModel, run_seeds, square_program
from umbmark.studies import reference

FIG11 = ErrorParams(ed=1.00084, eb=336.17 / 340)


@pytest.mark.parametrize("method", ["exact", "midpoint", "euler"])
def test_replay_loop_matches_numpy(method):
    rng = np.random.default_rng(0)
    dl = rng.normal(0.01, 0.03, 2000)
    dr = rng.normal(0.01, 0.03, 2000)
    want = odometry.integrate(dl, dr, 0.4, (1.0, -1.0, 0.3), method, kernel="trig")
    got = reference.integrate(dl, dr, 0.4, (1.0, -1.0, 0.3), method)
    for a, b in zip(got, want):
        np.testing.assert_allclose(a, b, atol=1e-12, rtol=0)


def test_replay_loop_straight_and_quarter_circle():
    # straight: 100 samples of 1 cm on both wheels
    x, y, th = reference.integrate([0.01] * 100, [0.01] * 100, 0.5)
    assert (x[-1], y[-1], th[-1]) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)
    # a quarter circle of radius 1 m (wheelbase 0.5): exact arcs land on (1, 1)
    n = 50
    rl, rr = 1.0 - 0.25, 1.0 + 0.25
    x, y, th = reference.integrate([rl * math.pi / 2 / n] * n, [rr * math.pi / 2 / n] * n, 0.5)
    assert (x[-1], y[-1], th[-1]) == pytest.approx((1.0, 1.0, math.pi / 2), abs=1e-12)


NOISES = [
    NoiseModel(),
    NoiseModel(quantise=True),
    NoiseModel(slip_m_per_sqrt_m=1e-3),
    NoiseModel(bump_rate_per_m=5.0, bump_loss_m=3e-3),  # losses larger than a sample's travel too
    simulate.NOISE_PRESETS["paper"],
]


@pytest.mark.parametrize("noise", NOISES, ids=lambda n: repr(n)[:60])
@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_closed_loop_matches_vectorised_simulator(noise, direction):
    true = ErrorParams(ed=1.004, eb=0.97).true_params(LABMATE)
    model = OdometryParams.from_geometry(LABMATE)
    prog = square_program(direction, 1.0)
    motion = Motion(sample_period_s=0.02)
    per_true = {"wheelbase_m": np.array([0.33, 0.35, 0.34])}
    want = simulate.run_program(prog, true, model, 3, noise, motion, rngs=run_seeds(9, 3), true_per_run=per_true)
    got = reference.run_program(prog, true, model, 3, noise, motion, rngs=run_seeds(9, 3), true_per_run=per_true)
    for k in ("true_x", "true_y", "true_theta", "odo_x", "odo_y", "odo_theta", "abs_x", "abs_y", "abs_theta"):
        np.testing.assert_allclose(getattr(got, k), getattr(want, k), atol=1e-11, rtol=0, err_msg=k)


def test_one_step_per_segment_and_paper_figure():
    motion = Motion(sample_period_s=None)
    t = reference.simulate_umbmark(FIG11, motion=motion)
    assert umbmark_figures(t).emax_syst * 1e3 == pytest.approx(311.04, abs=0.01)
    want = simulate.simulate_umbmark(FIG11, motion=motion)
    np.testing.assert_allclose(t.x_abs, want.x_abs, atol=1e-12)


def test_errors():
    true = FIG11.true_params(LABMATE)
    model = OdometryParams.from_geometry(LABMATE)
    with pytest.raises(InputError, match="generator"):
        reference.run_program(square_program("cw", 1.0), true, model, 2, simulate.NOISE_PRESETS["paper"])
    with pytest.raises(InputError, match="empty"):
        reference.run_program((), true, model, 1)
    with pytest.raises(InputError, match="integrator"):
        reference.integrate([0.1], [0.1], 0.3, integrator="rk4")
