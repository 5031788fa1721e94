"""umbmark.model.batch: a batch gives the results of the same robots one by one, and of the
per-sample reference loop."""

import subprocess
import sys

import numpy as np
import pytest

from umbmark.errors import InputError
from umbmark.metrics import umbmark_figures
from umbmark.model import batch, simulate
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, OdometryParams
from umbmark.model.simulate import Motion, NoiseModel, run_seeds, square_program
from umbmark.studies import reference

COLS = ("x_abs", "y_abs", "x_odo", "y_odo", "theta_abs", "theta_odo")
ENGINES = ["numpy"] + (["numba"] if batch.have_numba() else [])
ROBOTS = [
    ErrorParams(ed=1.00084, eb=336.17 / 340),
    ErrorParams(ed=0.997, eb=1.02),
    ErrorParams(ed=1.0, eb=1.0, es=1.01),
]
CALS = [None, Calibration(0.999, 1.001, 0.338), None]


def _same(a, b, tol):
    for k in COLS:
        np.testing.assert_allclose(np.asarray(getattr(a, k)), np.asarray(getattr(b, k)), atol=tol, rtol=0, err_msg=k)
    assert list(a.direction) == list(b.direction)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("noise", ["none", "paper"])
def test_batch_equals_one_by_one(engine, noise):
    seeds = [11, 12, 13]
    got = batch.simulate_batch(ROBOTS, side_m=2.0, n_runs=3, calibrations=CALS, noise=noise, seeds=seeds, engine=engine)
    assert len(got) == 3
    for tab, e, c, s in zip(got, ROBOTS, CALS, seeds):
        want = simulate.simulate_umbmark(e, side_m=2.0, n_runs=3, calibration=c, noise=noise, seed=s)
        # to rounding: numpy sums over a longer padded row; numba composes headings as rotations
        _same(tab, want, 1e-10 if engine == "numba" else 1e-12)


@pytest.mark.skipif(not batch.have_numba(), reason="numba not installed")
def test_numba_engine_independent_of_chunks_and_threads():
    rng = np.random.default_rng(0)
    robots = [ErrorParams(ed=1 + rng.normal(0, 2e-3), eb=1 + rng.normal(0, 1e-2)) for _ in range(12)]
    a = batch.simulate_batch(robots, side_m=1.0, n_runs=2, noise="paper", seeds=5, engine="numba", chunk_runs=1000)
    b = batch.simulate_batch(
        robots, side_m=1.0, n_runs=2, noise="paper", seeds=5, engine="numba", chunk_runs=5, threads=3
    )
    c = batch.simulate_batch(
        robots[4:9], side_m=1.0, n_runs=2, noise="paper", seeds=np.random.SeedSequence(5).spawn(12)[4:9], engine="numba"
    )
    for x, y in zip(a, b):
        _same(x, y, 0.0)  # bit-identical
    for x, y in zip(a[4:9], c):
        _same(x, y, 0.0)


@pytest.mark.parametrize("engine", ENGINES)
def test_matches_reference_loop(engine):
    seeds = [3, 4]
    got = batch.simulate_batch(
        ROBOTS[:2], side_m=1.5, n_runs=2, calibrations=CALS[:2], noise="paper", seeds=seeds, engine=engine
    )
    for tab, e, c, s in zip(got, ROBOTS, CALS, seeds):
        want = reference.simulate_umbmark(e, side_m=1.5, n_runs=2, calibration=c, noise="paper", seed=s)
        _same(tab, want, 1e-9)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize(
    "noise",
    [NoiseModel(quantise=True), NoiseModel(slip_m_per_sqrt_m=1e-3, bump_rate_per_m=5.0, bump_loss_m=3e-3)],
    ids=["quantise", "slip+bumps"],
)
def test_run_batch_matches_run_program_on_turns(engine, noise):
    true = {
        "left_m_per_pulse": np.array([4.7e-5, 4.8e-5]),
        "right_m_per_pulse": 4.71e-5,
        "wheelbase_m": np.array([0.33, 0.36]),
    }
    model = OdometryParams.from_geometry(LABMATE)
    prog = (simulate.Segment("turn", 2.5), simulate.Segment("straight", 0.3), simulate.Segment("turn", -4.0))
    motion = Motion(sample_period_s=0.013)
    want = simulate.run_program(prog, None, model, 2, noise, motion, rngs=run_seeds(1, 2), true_per_run=true)
    got = batch.run_batch(prog, true, model, noise, motion, rngs=run_seeds(1, 2), engine=engine)
    for k in ("true_x", "true_y", "true_theta", "odo_x", "odo_y", "odo_theta", "abs_x", "abs_y", "abs_theta"):
        np.testing.assert_allclose(getattr(got, k), getattr(want, k), atol=1e-10, rtol=0, err_msg=k)


@pytest.mark.parametrize("engine", ENGINES)
def test_paper_figure_kept(engine):
    for motion in (Motion(sample_period_s=None), Motion()):
        (tab,) = batch.simulate_batch([ROBOTS[0]], motion=motion, engine=engine)
        assert umbmark_figures(tab).emax_syst * 1e3 == pytest.approx(311.04, abs=0.01)


def test_errors():
    with pytest.raises(InputError, match="one per robot"):
        batch.simulate_batch(ROBOTS, seeds=[1, 2])
    with pytest.raises(InputError, match="one per robot"):
        batch.simulate_batch(ROBOTS, calibrations=[None])
    with pytest.raises(InputError, match="engine"):
        batch.simulate_batch(ROBOTS, engine="gpu")
    with pytest.raises(InputError, match="at least one robot"):
        batch.simulate_batch([])
    with pytest.raises(InputError, match="generator"):
        batch.run_batch(
            square_program("cw", 1.0),
            OdometryParams(1e-4, 1e-4, 0.3),
            OdometryParams(1e-4, 1e-4, 0.3),
            simulate.NOISE_PRESETS["paper"],
            n_runs=2,
        )
    with pytest.raises(InputError, match="positive"):
        batch.run_batch(
            square_program("cw", 1.0),
            {"left_m_per_pulse": -1.0, "right_m_per_pulse": 1e-4, "wheelbase_m": 0.3},
            OdometryParams(1e-4, 1e-4, 0.3),
        )


def test_importing_the_batch_module_does_not_import_numba():
    """numba is imported when a batch first needs it (an engine is chosen), not at import."""
    code = "import sys\nimport umbmark.model.batch\nprint('numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"
