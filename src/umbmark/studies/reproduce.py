"""Reproduce the paper's section 5 in simulation. Library side: no printing.

The study
---------
A simulated LabMate (340 mm nominal wheelbase, 4 x 4 m square, 0.2 m/s, stop and turn on the
spot, 5 runs per direction) runs the bi-directional square test (UMBmark), is calibrated with
the paper's correction (method ``bf``), and runs it again. Where the 3 x SEM rule
(:attr:`umbmark.metrics.UMBmarkResult.second_pass_recommended`) says so, a second
compensation pass is made on top of the first (the robot with its first calibration is "a new
uncompensated robot", :func:`umbmark.correct.result.compose`) and the test is run a third time.

The eight experiments of the paper's Table I:

* experiment 1: the robot of the paper's Fig. 11 (``E_d = 1.00084``, ``b = 336.17 mm`` against
  340 mm nominal), exactly;
* experiments 2, 3-5 and 6: the same LabMate on other days: the Fig. 11 errors ``E_d - 1`` and
  ``E_b - 1`` each multiplied by an independent log-normal factor ``exp(v z)``, ``z ~ N(0, 1)``,
  ``v = 0.15`` (:data:`ROBOT_VARIATION`), drawn from the study seed. Experiments 3, 4 and 5
  share one robot, one set of uncalibrated runs and one set of correction factors, as in the
  paper ("These 3 experiments used the same set of uncalibrated results and identical
  correction factors"); each has its own runs after calibration;
* experiment 7: the Fig. 11 robot with three loops of masking tape on the right wheel;
  experiment 8: the Fig. 11 robot with five loops on the left wheel. A loop adds twice the
  tape's thickness to the wheel's diameter (:func:`tape_errors`); see :data:`TAPE_LAYER_M`.

Every simulated test has its own seed, ``SeedSequence(study_seed, spawn_key=(1, exp, pass))``,
split like :func:`umbmark.model.simulate.simulate_umbmark` (cw runs, then ccw runs, one generator per
run), so a test's runs do not depend on the batch they are simulated in, nor on how many study
seeds are run: the default seed's table is the first seed of the distribution.

Simulation settings (:class:`StudyConfig`): sampling period 50 ms (the paper's controller
sampled below 10 ms; the study batches tens of thousands of runs). The ``paper`` noise preset
is used for wheel slip, floor bumps and the sonar calibrator's absolute measurement noise, but
with *unquantised* encoders by default, so that every segment stops exactly on its target:
with quantised encoders the robot stops at the first sample past the target, and at 50 ms
that over-turns every 90 deg turn by a deterministic ~1 deg (0.3 deg at 10 ms), which the
paper's controller did not do. The slip is a random walk in distance and the bumps a rate per
metre, so the spread of the return errors does not depend on the sampling period (measured:
see the README section "reproducing the paper").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from umbmark.correct import CorrectionResult, bf_correction
from umbmark.errors import InputError
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.geometry import (
    FIG11_ERRORS,  # the paper's Fig. 11 robot: E_d = 1.00084, b = 336.17 mm
    LABMATE,
    Calibration,
    ErrorParams,
    Geometry,
    OdometryParams,
    wrap_angle,
)
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import (
    NOISE_PRESETS,
    Motion,
    NoiseModel,
    child_seeds,
    run_program,
    run_seeds,
    square_program,
)

__all__ = [
    "FIG11_ERRORS",
    "PAPER_TABLE_I",
    "PAPER_SIGMA_MM",
    "PAPER_SEM_MM",
    "ROBOT_VARIATION",
    "TAPE_LAYER_M",
    "STUDY_NOISE",
    "StudyConfig",
    "TestSpec",
    "PassResult",
    "Experiment",
    "Distribution",
    "Study",
    "Pitfall",
    "tape_errors",
    "experiment_robots",
    "test_seed",
    "simulate_tests",
    "run_seed_experiments",
    "run_study",
    "seed_groups",
    "uni_directional_pitfall",
    "run_trajectories",
]


# Table I of the paper: E_max,syst [mm] before / after compensation, the improvement it states.
PAPER_TABLE_I: tuple[dict, ...] = (
    dict(
        id=1, before_mm=317.0, after_mm=21.0, second_mm=None, improvement="15-fold", comment="details shown in Fig. 11"
    ),
    dict(id=2, before_mm=349.0, after_mm=32.0, second_mm=None, improvement="11-fold", comment=""),
    dict(
        id=3,
        before_mm=310.0,
        after_mm=31.0,
        second_mm=None,
        improvement="10-fold",
        comment="exps 3-5: same uncalibrated runs and correction factors",
    ),
    dict(id=4, before_mm=310.0, after_mm=14.0, second_mm=None, improvement="22-fold", comment=""),
    dict(id=5, before_mm=310.0, after_mm=26.0, second_mm=None, improvement="12-fold", comment=""),
    dict(id=6, before_mm=403.0, after_mm=35.0, second_mm=None, improvement="11-fold", comment=""),
    dict(
        id=7,
        before_mm=423.0,
        after_mm=66.0,
        second_mm=20.0,
        improvement="21-fold",
        comment="right wheel + 3 loops of masking tape; two compensation passes",
    ),
    dict(
        id=8,
        before_mm=232.0,
        after_mm=12.0,
        second_mm=None,
        improvement="19-fold",
        comment="left wheel + 5 loops of masking tape",
    ),
)
PAPER_SIGMA_MM = 25.0
PAPER_SEM_MM = 11.2

# How many experiments with a second pass (the first ones, in seed order) the study reports.
N_SECOND_PASS_EXAMPLES = 5

# Day-to-day variation of the LabMate's errors for experiments 2-6 (log-normal, relative).
ROBOT_VARIATION = 0.15

# Effective thickness of one layer of masking tape on the wheel (metres). The paper gives
# neither the tape's thickness nor the LabMate's wheel diameter. With the 150 mm wheels of
# kinematics.LABMATE, a layer of 0.1 mm (a typical masking tape, unloaded) would raise the
# noise-free E_max,syst before calibration of experiment 7 to about 855 mm and of experiment 8
# to about 999 mm, while the paper measured 423 and 232 mm; an effective 0.02 mm per layer
# (a tape pressed into a loaded tyre changes the rolling diameter by less than its thickness)
# gives 422 mm for experiment 7. It is therefore an *inferred* value (from experiment 7's
# before figure), not a measured one; experiment 8 is then a prediction (278 mm, noise-free).
TAPE_LAYER_M = 0.02e-3

# The paper preset with unquantised encoders (exact stops); see the module docstring.
STUDY_NOISE = replace(NOISE_PRESETS["paper"], quantise=False, name="paper, unquantised encoders (exact stops)")

_PASS_BEFORE, _PASS_AFTER, _PASS_SECOND = 0, 1, 2
_ROBOT_KEY = 0
_TEST_KEY = 1
_PITFALL_KEY = 2
_TRAJ_KEY = 3


def tape_errors(
    base: ErrorParams, geometry: Geometry, right_layers: int = 0, left_layers: int = 0, layer_m: float = TAPE_LAYER_M
) -> ErrorParams:
    """The errors of a robot whose wheels got loops of tape: each loop adds ``2 * layer_m`` to
    that wheel's diameter (E_d and E_s change, E_b does not).

    Parameters
    ----------
    base : ErrorParams
        The robot's errors without tape.
    geometry : Geometry
        Its nominal geometry.
    right_layers, left_layers : int
        Loops of tape on the right and on the left wheel.
    layer_m : float
        Effective thickness of one loop.

    Returns
    -------
    ErrorParams

    Raises
    ------
    InputError
        If a number of loops is negative or the thickness is negative or not finite.
    """
    if right_layers < 0 or left_layers < 0:
        raise InputError("the number of tape loops must be >= 0")
    if not (math.isfinite(layer_m) and layer_m >= 0):
        raise InputError(f"tape thickness must be >= 0, got {layer_m!r}")
    d_left, d_right = base.diameters_m(geometry)
    d_left += 2.0 * left_layers * layer_m
    d_right += 2.0 * right_layers * layer_m
    return ErrorParams(ed=d_right / d_left, eb=base.eb, es=0.5 * (d_left + d_right) / geometry.wheel_diameter_m)


@dataclass(frozen=True)
class StudyConfig:
    """Everything that defines the study; the same config gives the same numbers.

    Attributes
    ----------
    seed : int
        The first study seed (its Table I is the one shown).
    seeds : int
        Number of study seeds (``seed``, ``seed + 1``, ...).
    n_runs : int
        Runs per direction in every test.
    side_m : float
        Side of the square.
    geometry : Geometry
        The robot's nominal geometry.
    noise : NoiseModel
        Non-systematic errors (default :data:`STUDY_NOISE`).
    sample_period_s : float
        Controller sampling period of the simulation.
    tape_layer_m : float
        Effective thickness of one loop of tape (experiments 7 and 8).
    variation : float
        Relative day-to-day variation of the robot's errors (experiments 2-6).
    chunk_runs : int
        About this many runs are simulated in one batch.

    Raises
    ------
    InputError
        On construction, if a setting is out of its range.
    """

    seed: int = 1
    seeds: int = 100
    n_runs: int = 5
    side_m: float = 4.0
    geometry: Geometry = LABMATE
    noise: NoiseModel = STUDY_NOISE
    sample_period_s: float = 0.05
    tape_layer_m: float = TAPE_LAYER_M
    variation: float = ROBOT_VARIATION
    chunk_runs: int = 1000

    def __post_init__(self):
        if not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {self.seed!r}")
        if not isinstance(self.seeds, (int, np.integer)) or self.seeds < 1:
            raise InputError(f"the number of seeds must be >= 1, got {self.seeds!r}")
        if not isinstance(self.n_runs, (int, np.integer)) or self.n_runs < 2:
            raise InputError(f"runs per direction must be >= 2 (the 3 x SEM rule needs a spread), got {self.n_runs!r}")
        for name in ("side_m", "sample_period_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be positive, got {v!r}")
        if not (math.isfinite(self.tape_layer_m) and 0 <= self.tape_layer_m < 1e-3):
            raise InputError(f"tape thickness must be in [0, 1) mm, got {self.tape_layer_m * 1e3!r} mm")
        if not (math.isfinite(self.variation) and 0 <= self.variation <= 1):
            raise InputError(f"robot variation must be in [0, 1], got {self.variation!r}")
        if self.chunk_runs < 10:
            raise InputError("chunk_runs must be >= 10")

    @property
    def motion(self) -> Motion:
        """The motion of every run: default speed, this sampling period."""
        return Motion(sample_period_s=self.sample_period_s)

    @property
    def seed_list(self) -> list[int]:
        """The study seeds, ``seed`` to ``seed + seeds - 1``."""
        return list(range(int(self.seed), int(self.seed) + int(self.seeds)))

    def to_dict(self) -> dict:
        """The settings as JSON-able values, in millimetres (the ``config`` of the study's JSON)."""
        n = self.noise
        return {
            "seed": int(self.seed),
            "seeds": int(self.seeds),
            "runs_per_direction": int(self.n_runs),
            "side_mm": self.side_m * 1e3,
            "wheelbase_nominal_mm": self.geometry.wheelbase_m * 1e3,
            "wheel_diameter_mm": self.geometry.wheel_diameter_m * 1e3,
            "speed_m_s": self.motion.speed_m_s,
            "sample_period_ms": self.sample_period_s * 1e3,
            "noise": {
                "name": n.name,
                "slip_m_per_sqrt_m": n.slip_m_per_sqrt_m,
                "bump_rate_per_m": n.bump_rate_per_m,
                "bump_loss_mm": n.bump_loss_m * 1e3,
                "quantise": n.quantise,
                "abs_xy_std_mm": n.abs_xy_std_m * 1e3,
                "abs_theta_std_deg": math.degrees(n.abs_theta_std_rad),
            },
            "tape_layer_thickness_mm": self.tape_layer_m * 1e3,
            "robot_variation": self.variation,
        }


def experiment_robots(seed: int, cfg: StudyConfig | None = None) -> list[ErrorParams]:
    """The true errors of the eight experiments for one study seed (3, 4, 5 are one robot).

    Parameters
    ----------
    seed : int
        The study seed.
    cfg : StudyConfig, optional
        The study (its geometry, variation and tape thickness).

    Returns
    -------
    list of ErrorParams
        Eight entries, experiment 1 first.
    """
    cfg = cfg or StudyConfig()
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(_ROBOT_KEY,)))
    z = rng.standard_normal((3, 2))
    ed1, eb1 = FIG11_ERRORS.ed - 1.0, FIG11_ERRORS.eb - 1.0

    def varied(k):
        return ErrorParams(
            ed=1.0 + ed1 * math.exp(cfg.variation * z[k, 0]), eb=1.0 + eb1 * math.exp(cfg.variation * z[k, 1])
        )

    r2, r35, r6 = varied(0), varied(1), varied(2)
    r7 = tape_errors(FIG11_ERRORS, cfg.geometry, right_layers=3, layer_m=cfg.tape_layer_m)
    r8 = tape_errors(FIG11_ERRORS, cfg.geometry, left_layers=5, layer_m=cfg.tape_layer_m)
    return [FIG11_ERRORS, r2, r35, r35, r35, r6, r7, r8]


def test_seed(study_seed: int, exp_id: int, pass_no: int) -> np.random.SeedSequence:
    """The seed of one simulated test (a fresh SeedSequence each call).

    Parameters
    ----------
    study_seed : int
        The study seed.
    exp_id : int
        The experiment (1-8).
    pass_no : int
        The test: before calibration, after the first or after the second pass.

    Returns
    -------
    numpy.random.SeedSequence
    """
    return np.random.SeedSequence(int(study_seed), spawn_key=(_TEST_KEY, int(exp_id), int(pass_no)))


@dataclass(frozen=True)
class TestSpec:
    """One bi-directional test to simulate: the robot's true errors, the calibration its
    odometry runs with, and the seed of its runs."""

    __test__ = False  # not a pytest class

    errors: ErrorParams
    calibration: Calibration | None
    seed: np.random.SeedSequence


def _chunks(n, size):
    for i in range(0, n, size):
        yield slice(i, min(n, i + size))


def simulate_tests(tests: list[TestSpec], cfg: StudyConfig) -> list[RunsTable]:
    """Simulate many bi-directional tests in numpy batches (one batch per direction and chunk).

    Test i gives exactly the runs ``simulate_umbmark(t.errors, cfg.geometry, cfg.side_m,
    cfg.n_runs, t.calibration, cfg.noise, cfg.motion, seed=t.seed)`` would give.

    Parameters
    ----------
    tests : list of TestSpec
        The tests.
    cfg : StudyConfig
        The study (geometry, side, runs, noise, motion, batch size).

    Returns
    -------
    list of RunsTable
        One per test, in order.
    """
    if not tests:
        return []
    n = cfg.n_runs
    geo = cfg.geometry
    per_dir = {}
    cw_rngs, ccw_rngs = [], []
    tl, tr, tb, ml, mr, mb = ([] for _ in range(6))
    for t in tests:
        cw_ss, ccw_ss = child_seeds(t.seed, 2)  # the same seed split as simulate_umbmark
        cw_rngs += run_seeds(cw_ss, n)
        ccw_rngs += run_seeds(ccw_ss, n)
        tp = t.errors.true_params(geo)
        mp = OdometryParams.from_geometry(geo, t.calibration)
        tl.append(tp.left_m_per_pulse)
        tr.append(tp.right_m_per_pulse)
        tb.append(tp.wheelbase_m)
        ml.append(mp.left_m_per_pulse)
        mr.append(mp.right_m_per_pulse)
        mb.append(mp.wheelbase_m)
    rep = lambda v: np.repeat(np.asarray(v, dtype=float), n)  # noqa: E731
    true_all = dict(left_m_per_pulse=rep(tl), right_m_per_pulse=rep(tr), wheelbase_m=rep(tb))
    model_all = dict(left_m_per_pulse=rep(ml), right_m_per_pulse=rep(mr), wheelbase_m=rep(mb))
    total = len(tests) * n
    for direction, rngs in (("cw", cw_rngs), ("ccw", ccw_rngs)):
        prog = square_program(direction, cfg.side_m)
        out = {k: np.empty(total) for k in ("abs_x", "abs_y", "abs_theta", "odo_x", "odo_y", "odo_theta")}
        for sl in _chunks(total, cfg.chunk_runs):
            res = run_program(
                prog,
                None,
                None,
                sl.stop - sl.start,
                cfg.noise,
                cfg.motion,
                rngs=rngs[sl],
                true_per_run={k: v[sl] for k, v in true_all.items()},
                model_per_run={k: v[sl] for k, v in model_all.items()},
            )
            for k in out:
                out[k][sl] = getattr(res, k)
        per_dir[direction] = out
    tables = []
    for i in range(len(tests)):
        sl = slice(i * n, (i + 1) * n)
        parts = [per_dir["cw"], per_dir["ccw"]]
        tables.append(
            RunsTable.from_columns(
                direction=np.array(["cw"] * n + ["ccw"] * n),
                x_abs=np.concatenate([p["abs_x"][sl] for p in parts]),
                y_abs=np.concatenate([p["abs_y"][sl] for p in parts]),
                x_odo=np.concatenate([p["odo_x"][sl] for p in parts]),
                y_odo=np.concatenate([p["odo_y"][sl] for p in parts]),
                theta_abs=wrap_angle(np.concatenate([p["abs_theta"][sl] for p in parts])),
                theta_odo=wrap_angle(np.concatenate([p["odo_theta"][sl] for p in parts])),
                run=np.concatenate([np.arange(1, n + 1)] * 2),
            )
        )
    return tables


@dataclass
class PassResult:
    """One compensation pass: the correction and the test run with it."""

    correction: CorrectionResult
    runs: RunsTable
    result: UMBmarkResult


@dataclass
class Experiment:
    """One experiment of Table I for one study seed (lengths in metres)."""

    id: int
    seed: int
    errors: ErrorParams
    before_runs: RunsTable
    before: UMBmarkResult
    first: PassResult
    second: PassResult | None = None
    wheelbase_nominal_m: float = LABMATE.wheelbase_m

    @property
    def emax_before(self) -> float:
        """E_max,syst of the uncalibrated robot (metres)."""
        return self.before.emax_syst

    @property
    def emax_after(self) -> float:
        """E_max,syst after the first pass (metres)."""
        return self.first.result.emax_syst

    @property
    def emax_final(self) -> float:
        """E_max,syst after the last pass made (metres)."""
        return (self.second or self.first).result.emax_syst

    @property
    def improvement(self) -> float:
        """E_max,syst before / after the first pass."""
        return self.emax_before / self.emax_after if self.emax_after > 0 else math.inf

    @property
    def improvement_final(self) -> float:
        """E_max,syst before / after the last pass."""
        return self.emax_before / self.emax_final if self.emax_final > 0 else math.inf

    def to_dict(self) -> dict:
        """The experiment as JSON-able values in millimetres (one entry of the study's ``experiments``)."""
        r1 = self.first.result
        rule = r1.sem_rule
        sem_before, std_after, sem_after = self.before.worst.sem, r1.worst.std, r1.worst.sem
        # a study's tests have at least 2 runs per direction (StudyConfig.n_runs): every spread is known
        assert sem_before is not None and std_after is not None and sem_after is not None
        d = {
            "id": self.id,
            "seed": self.seed,
            "true_Ed": self.errors.ed,
            "true_wheelbase_mm": self.errors.eb * self.wheelbase_nominal_m * 1e3,
            "true_Es": self.errors.es,
            "emax_before_mm": self.emax_before * 1e3,
            "emax_after_mm": self.emax_after * 1e3,
            "improvement": self.improvement,
            "sem_before_mm": sem_before * 1e3,
            "std_after_mm": std_after * 1e3,
            "sem_after_mm": sem_after * 1e3,
            "three_sem_after_mm": None if rule is None else rule * 1e3,
            "second_pass_recommended": r1.second_pass_recommended,
            "correction": _corr_dict(self.first.correction),
            "second_pass": None,
            "emax_final_mm": self.emax_final * 1e3,
            "improvement_final": self.improvement_final,
        }
        if self.second is not None:
            r2 = self.second.result
            d["second_pass"] = {
                "emax_before_mm": self.emax_after * 1e3,
                "emax_after_mm": r2.emax_syst * 1e3,
                "improvement": self.improvement_final,
                "three_sem_after_mm": None if r2.sem_rule is None else r2.sem_rule * 1e3,
                "correction": _corr_dict(self.second.correction),
            }
        return d


def _corr_dict(c: CorrectionResult) -> dict:
    """A correction of :func:`umbmark.correct.bf_correction` as JSON (mm, deg)."""
    wheelbase_m = c.calibration.wheelbase_m
    # bf_correction always gives the wheelbase and both angles
    assert wheelbase_m is not None and c.alpha is not None and c.beta is not None
    return {
        "Ed": c.ed,
        "Eb": c.eb,
        "c_left": c.calibration.c_left,
        "c_right": c.calibration.c_right,
        "wheelbase_mm": wheelbase_m * 1e3,
        "alpha_deg": math.degrees(c.alpha),
        "beta_deg": math.degrees(c.beta),
    }


_GROUPS = (1, 2, 3, 6, 7, 8)  # experiments with their own uncalibrated runs (3 stands for 3-5)
_GROUP_OF = {1: 1, 2: 2, 3: 3, 4: 3, 5: 3, 6: 6, 7: 7, 8: 8}


def run_seed_experiments(seeds: list[int], cfg: StudyConfig) -> dict[int, list[Experiment]]:
    """The eight experiments for each study seed, simulated in batches across seeds.

    Parameters
    ----------
    seeds : list of int
        Study seeds.
    cfg : StudyConfig
        The study.

    Returns
    -------
    dict
        Seed -> its eight :class:`Experiment` objects, experiment 1 first.
    """
    geo = cfg.geometry
    b_nom = geo.wheelbase_m
    robots = {s: experiment_robots(s, cfg) for s in seeds}
    # pass 0: uncalibrated runs (one per group)
    keys0 = [(s, g) for s in seeds for g in _GROUPS]
    runs0 = simulate_tests([TestSpec(robots[s][g - 1], None, test_seed(s, g, _PASS_BEFORE)) for s, g in keys0], cfg)
    before = {}
    for k, rt in zip(keys0, runs0):
        res = umbmark_figures(rt)
        before[k] = (rt, res, bf_correction(res, cfg.side_m, b_nom))
    # pass 1: runs with the first calibration (every experiment)
    keys1 = [(s, e) for s in seeds for e in range(1, 9)]
    runs1 = simulate_tests(
        [
            TestSpec(robots[s][e - 1], before[(s, _GROUP_OF[e])][2].calibration, test_seed(s, e, _PASS_AFTER))
            for s, e in keys1
        ],
        cfg,
    )
    exps = {}
    for (s, e), rt in zip(keys1, runs1):
        rt0, res0, corr = before[(s, _GROUP_OF[e])]
        exps[(s, e)] = Experiment(
            e, s, robots[s][e - 1], rt0, res0, PassResult(corr, rt, umbmark_figures(rt)), wheelbase_nominal_m=b_nom
        )
    # pass 2: where the 3 x SEM rule calls for it, a second compensation on top of the first
    keys2, specs2, corr2 = [], [], []
    for k in keys1:
        ex = exps[k]
        if ex.first.result.second_pass_recommended:
            cal1 = ex.first.correction.calibration
            assert cal1.wheelbase_m is not None  # bf_correction always gives the wheelbase
            c2 = bf_correction(ex.first.result, cfg.side_m, cal1.wheelbase_m, prior=cal1)
            keys2.append(k)
            corr2.append(c2)
            specs2.append(TestSpec(ex.errors, c2.calibration, test_seed(k[0], k[1], _PASS_SECOND)))
    for k, c2, rt in zip(keys2, corr2, simulate_tests(specs2, cfg)):
        exps[k].second = PassResult(c2, rt, umbmark_figures(rt))
    return {s: [exps[(s, e)] for e in range(1, 9)] for s in seeds}


@dataclass
class Distribution:
    """The study over many seeds: pooled over all experiments and seeds."""

    seeds: list[int]
    emax_before: np.ndarray  # (S, 8) metres
    emax_after: np.ndarray
    emax_final: np.ndarray
    second: np.ndarray  # (S, 8) bool
    std_after: np.ndarray  # radial std of the worst direction after the first pass

    @property
    def improvement_final(self) -> np.ndarray:
        """E_max,syst before / final, (seeds, 8)."""
        return self.emax_before / self.emax_final

    @property
    def improvement_first(self) -> np.ndarray:
        """E_max,syst before / after the first pass, (seeds, 8)."""
        return self.emax_before / self.emax_after

    def to_dict(self) -> dict:
        """Medians and 10th / 90th percentiles over all experiments, and per experiment (mm)."""
        imp = self.improvement_final.ravel()
        imp1 = self.improvement_first.ravel()
        pct = lambda a, q: float(np.percentile(a, q))  # noqa: E731
        fin = self.emax_final.ravel() * 1e3
        aft = self.emax_after.ravel() * 1e3
        bef = self.emax_before.ravel() * 1e3
        sec = self.second
        with_second = sec.ravel()
        return {
            "seeds": len(self.seeds),
            "seed_first": self.seeds[0],
            "seed_last": self.seeds[-1],
            "experiments_per_seed": int(self.emax_before.shape[1]),
            "improvement_median": pct(imp, 50),
            "improvement_p10": pct(imp, 10),
            "improvement_p90": pct(imp, 90),
            "improvement_first_pass_median": pct(imp1, 50),
            "improvement_first_pass_p10": pct(imp1, 10),
            "improvement_first_pass_p90": pct(imp1, 90),
            "fraction_improvement_at_least_10": float(np.mean(imp >= 10)),
            "emax_before_median_mm": pct(bef, 50),
            "emax_before_p10_mm": pct(bef, 10),
            "emax_before_p90_mm": pct(bef, 90),
            "emax_after_median_mm": pct(aft, 50),
            "emax_after_p10_mm": pct(aft, 10),
            "emax_after_p90_mm": pct(aft, 90),
            "emax_final_median_mm": pct(fin, 50),
            "emax_final_p10_mm": pct(fin, 10),
            "emax_final_p90_mm": pct(fin, 90),
            "std_after_median_mm": pct(self.std_after.ravel() * 1e3, 50),
            "second_pass_fraction": float(np.mean(with_second)),
            "second_pass_emax_before_median_mm": pct(aft[with_second], 50) if with_second.any() else None,
            "second_pass_emax_after_median_mm": pct(fin[with_second], 50) if with_second.any() else None,
            "per_experiment": [
                {
                    "id": e + 1,
                    "emax_before_median_mm": pct(self.emax_before[:, e] * 1e3, 50),
                    "emax_after_median_mm": pct(self.emax_after[:, e] * 1e3, 50),
                    "emax_final_median_mm": pct(self.emax_final[:, e] * 1e3, 50),
                    "improvement_median": pct(self.improvement_final[:, e], 50),
                    "second_pass_fraction": float(np.mean(sec[:, e])),
                }
                for e in range(self.emax_before.shape[1])
            ],
        }


@dataclass
class Study:
    """The whole study: Table I of the first seed, the distribution over all seeds, the pitfall.

    Attributes
    ----------
    config : StudyConfig
        The settings.
    experiments : list of Experiment
        The eight experiments of the first seed.
    distribution : Distribution
        The study over all seeds.
    pitfall : Pitfall or None
        The uni-directional pitfall, if it was run.
    second_pass_examples : list of Experiment
        The first experiments (in seed order) where the 3 x SEM rule called for a second pass.
    """

    config: StudyConfig
    experiments: list[Experiment]  # the default seed's (the first seed)
    distribution: Distribution
    pitfall: Pitfall | None = None
    second_pass_examples: list[Experiment] = field(default_factory=list)

    def to_dict(self) -> dict:
        """The study as JSON-able values, floats rounded to 12 significant digits (stable bytes)."""
        d = {
            "study": "Borenstein & Feng section 5 (Table I) in simulation",
            "config": self.config.to_dict(),
            "experiments": [e.to_dict() for e in self.experiments],
            "paper_table_i": [dict(p) for p in PAPER_TABLE_I],
            "paper_sigma_mm": PAPER_SIGMA_MM,
            "paper_sem_mm": PAPER_SEM_MM,
            "distribution": self.distribution.to_dict(),
            "second_pass_examples": [e.to_dict() for e in self.second_pass_examples],
            "tape_model": tape_model(self.config),
        }
        if self.pitfall is not None:
            d["pitfall"] = self.pitfall.to_dict()
        return _rounded(d)


def _rounded(o):
    """Round floats (12 significant digits) so that the JSON is stable across platforms."""
    if isinstance(o, float):
        return float(f"{o:.12g}") if math.isfinite(o) else o
    if isinstance(o, dict):
        return {k: _rounded(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_rounded(v) for v in o]
    if isinstance(o, np.generic):
        return _rounded(o.item())
    return o


def tape_model(cfg: StudyConfig) -> dict:
    """The tape experiments' robots and their noise-free E_max,syst before calibration.

    Parameters
    ----------
    cfg : StudyConfig
        The study (tape thickness, geometry, side).

    Returns
    -------
    dict
        ``layer_thickness_mm``, ``wheel_diameter_mm``, ``fig11_noise_free_emax_before_mm`` and
        ``exp7``, ``exp8`` (loops, E_d, E_s, noise-free E_max,syst before).
    """
    out: dict[str, Any] = {
        "layer_thickness_mm": cfg.tape_layer_m * 1e3,
        "wheel_diameter_mm": cfg.geometry.wheel_diameter_m * 1e3,
    }
    base_free = _noise_free_emax(FIG11_ERRORS, cfg)
    out["fig11_noise_free_emax_before_mm"] = base_free * 1e3
    for eid, right, left in ((7, 3, 0), (8, 0, 5)):
        err = tape_errors(FIG11_ERRORS, cfg.geometry, right, left, cfg.tape_layer_m)
        out[f"exp{eid}"] = {
            "right_loops": right,
            "left_loops": left,
            "Ed": err.ed,
            "Es": err.es,
            "noise_free_emax_before_mm": _noise_free_emax(err, cfg) * 1e3,
        }
    return out


def _noise_free_emax(errors: ErrorParams, cfg: StudyConfig, calibration: Calibration | None = None) -> float:
    from umbmark.model.simulate import simulate_umbmark

    rt = simulate_umbmark(errors, cfg.geometry, cfg.side_m, 1, calibration, "none", Motion(sample_period_s=None))
    return umbmark_figures(rt).emax_syst


def seed_groups(cfg: StudyConfig) -> list[list[int]]:
    """The study seeds cut into the groups simulated as one batch each (bounded batch size:
    about ``cfg.chunk_runs`` runs); each group is one task of the sweep in :func:`run_study`.

    Parameters
    ----------
    cfg : StudyConfig
        The study.

    Returns
    -------
    list of list of int
        The groups, in seed order.
    """
    seeds = cfg.seed_list
    per_group = max(1, cfg.chunk_runs // (cfg.n_runs * 8))
    return [seeds[i : i + per_group] for i in range(0, len(seeds), per_group)]


def _seed_group_task(task: tuple[list[int], StudyConfig]) -> dict[int, list[Experiment]]:
    """One sweep task (module level, so a process pool or Dask can pickle it)."""
    seeds, cfg = task
    return run_seed_experiments(seeds, cfg)


def run_study(
    cfg: StudyConfig | None = None, pitfall: bool = True, workers: int | None = None, dask=None, on_progress=None
) -> Study:
    """The whole study: Table I for the first seed, the distribution over all seeds, and the
    uni-directional pitfall (first seed).

    The groups of seeds (:func:`seed_groups`) are simulated through :func:`umbmark.studies.sweep.map`:
    ``workers`` local processes (``None``: all cores; ``1``: in this process) or a Dask
    cluster (``dask``: an address, ``"local"`` or a ``distributed.Client``). Every test carries
    its own seed and the groups are the same whatever the backend, so the study is identical
    (to the bit) on every backend.

    Parameters
    ----------
    cfg : StudyConfig, optional
        The study (default: :class:`StudyConfig` ``()``).
    pitfall : bool
        Also run the uni-directional pitfall.
    workers : int, optional
        Local processes.
    dask : str or distributed.Client, optional
        A Dask cluster instead of local processes.
    on_progress : callable, optional
        ``on_progress(seeds_done, seeds_total)``, called as groups finish.

    Returns
    -------
    Study
    """
    from umbmark.studies import sweep

    cfg = cfg or StudyConfig()
    seeds = cfg.seed_list
    groups = seed_groups(cfg)
    tick = None
    if on_progress is not None:
        per_group = len(groups[0])

        def tick(done, _total):
            on_progress(min(done * per_group, len(seeds)), len(seeds))

    all_exps: dict[int, list[Experiment]] = {}
    for part in sweep.map(_seed_group_task, [(g, cfg) for g in groups], workers=workers, dask=dask, on_progress=tick):
        all_exps.update(part)
    arr = lambda f: np.array([[f(e) for e in all_exps[s]] for s in seeds], dtype=float)  # noqa: E731
    dist = Distribution(
        seeds=seeds,
        emax_before=arr(lambda e: e.emax_before),
        emax_after=arr(lambda e: e.emax_after),
        emax_final=arr(lambda e: e.emax_final),
        second=arr(lambda e: e.second is not None).astype(bool),
        std_after=arr(lambda e: e.first.result.worst.std),
    )
    pf = uni_directional_pitfall(cfg) if pitfall else None
    # the first experiments (in seed order) where the rule called for a second pass
    examples = [e for s in seeds for e in all_exps[s] if e.second is not None][:N_SECOND_PASS_EXAMPLES]
    return Study(cfg, all_exps[seeds[0]], dist, pf, second_pass_examples=examples)


# ---------------------------------------------------------------------------------------------
# The uni-directional pitfall (section 3.1, Figs. 3-4)


@dataclass
class Pitfall:
    """An experimenter tunes only the wheelbase until the cw runs close well.

    ``grid_m``: the wheelbases tried; ``cw_r_cg``: the cw centre-of-gravity distance the
    experimenter saw for each (``n_runs`` cw runs); ``ccw_r_cg``: what the ccw runs would have
    shown (the experimenter never ran them). ``tuned``: the bi-directional test of the robot
    with the tuned wheelbase (fresh runs); ``uncalibrated`` and ``bf``: the bi-directional
    test before calibration and after the paper's correction (same robot, fresh runs)."""

    errors: ErrorParams
    grid_m: np.ndarray
    cw_r_cg: np.ndarray
    ccw_r_cg: np.ndarray
    tuned_wheelbase_m: float
    uncalibrated_runs: RunsTable
    uncalibrated: UMBmarkResult
    tuned_runs: RunsTable
    tuned: UMBmarkResult
    bf_correction: CorrectionResult
    bf_runs: RunsTable
    bf: UMBmarkResult
    wheelbase_nominal_m: float = LABMATE.wheelbase_m

    def to_dict(self) -> dict:
        """The pitfall as JSON-able values in millimetres (the ``pitfall`` of the study's JSON)."""
        i = int(np.argmin(self.cw_r_cg))
        bf_wheelbase_m = self.bf_correction.calibration.wheelbase_m
        assert bf_wheelbase_m is not None  # bf_correction always gives the wheelbase
        return {
            "robot_Ed": self.errors.ed,
            "robot_wheelbase_mm": self.errors.eb * self.wheelbase_nominal_m * 1e3,
            "grid_mm": [float(self.grid_m[0] * 1e3), float(self.grid_m[-1] * 1e3), len(self.grid_m)],
            "tuned_wheelbase_mm": self.tuned_wheelbase_m * 1e3,
            "tuning_cw_r_cg_mm": float(self.cw_r_cg[i] * 1e3),
            "tuning_ccw_r_cg_unseen_mm": float(self.ccw_r_cg[i] * 1e3),
            "uncalibrated": _bi_dict(self.uncalibrated),
            "uni_directionally_tuned": _bi_dict(self.tuned),
            "bi_directional_bf": _bi_dict(self.bf),
            "bf_wheelbase_mm": bf_wheelbase_m * 1e3,
            "bf_Ed": self.bf_correction.ed,
        }


def _bi_dict(r: UMBmarkResult) -> dict:
    return {"cw_r_cg_mm": r.cw.r_cg * 1e3, "ccw_r_cg_mm": r.ccw.r_cg * 1e3, "emax_syst_mm": r.emax_syst * 1e3}


def uni_directional_pitfall(
    cfg: StudyConfig | None = None,
    errors: ErrorParams = FIG11_ERRORS,
    grid_mm: tuple[float, float, float] = (325.0, 355.0, 0.25),
) -> Pitfall:
    """Simulate the trial-and-error wheelbase tuning of section 3.1 on ``errors``' robot.

    For each wheelbase on the grid the experimenter runs ``n_runs`` cw squares and keeps the
    wheelbase whose cw centre of gravity is closest to the origin (the same run seeds for
    every trial, so the comparison between trials is not blurred by the noise). Then the
    robot with that wheelbase runs the bi-directional test.

    Parameters
    ----------
    cfg : StudyConfig, optional
        The study (seed, runs, side, noise).
    errors : ErrorParams
        The robot's true errors (default: the Fig. 11 robot).
    grid_mm : tuple of float
        ``(first, last, step)`` of the wheelbases tried, in millimetres.

    Returns
    -------
    Pitfall
    """
    cfg = cfg or StudyConfig()
    lo, hi, step = grid_mm
    grid = np.arange(round((hi - lo) / step) + 1) * step * 1e-3 + lo * 1e-3
    seed = int(cfg.seed)
    n = cfg.n_runs
    geo = cfg.geometry
    tp = errors.true_params(geo)
    cm = geo.m_per_pulse
    r_cg = {}
    for di, direction in enumerate(("cw", "ccw")):
        ss = np.random.SeedSequence(seed, spawn_key=(_PITFALL_KEY, di))
        xs, ys = [], []
        for sl in _chunks(len(grid), max(1, cfg.chunk_runs // n)):
            g = grid[sl]
            rngs = []
            for _ in g:  # common random numbers: every trial sees the same run seeds
                rngs += run_seeds(np.random.SeedSequence(ss.entropy, spawn_key=ss.spawn_key), n)
            res = run_program(
                square_program(direction, cfg.side_m),
                tp,
                None,
                len(g) * n,
                cfg.noise,
                cfg.motion,
                rngs=rngs,
                model_per_run=dict(
                    left_m_per_pulse=np.full(len(g) * n, cm),
                    right_m_per_pulse=np.full(len(g) * n, cm),
                    wheelbase_m=np.repeat(g, n),
                ),
            )
            ex = (res.abs_x - res.odo_x).reshape(len(g), n).mean(axis=1)
            ey = (res.abs_y - res.odo_y).reshape(len(g), n).mean(axis=1)
            xs.append(ex)
            ys.append(ey)
        r_cg[direction] = np.hypot(np.concatenate(xs), np.concatenate(ys))
    i = int(np.argmin(r_cg["cw"]))
    tuned_b = float(grid[i])
    s0 = np.random.SeedSequence(seed, spawn_key=(_PITFALL_KEY, 10))
    s1 = np.random.SeedSequence(seed, spawn_key=(_PITFALL_KEY, 11))
    s2 = np.random.SeedSequence(seed, spawn_key=(_PITFALL_KEY, 12))
    (unc_runs,) = simulate_tests([TestSpec(errors, None, s0)], cfg)
    unc = umbmark_figures(unc_runs)
    corr = bf_correction(unc, cfg.side_m, geo.wheelbase_m)
    tuned_runs, bf_runs = simulate_tests(
        [TestSpec(errors, Calibration(wheelbase_m=tuned_b), s1), TestSpec(errors, corr.calibration, s2)], cfg
    )
    return Pitfall(
        errors,
        grid,
        r_cg["cw"],
        r_cg["ccw"],
        tuned_b,
        unc_runs,
        unc,
        tuned_runs,
        umbmark_figures(tuned_runs),
        corr,
        bf_runs,
        umbmark_figures(bf_runs),
        geo.wheelbase_m,
    )


def run_trajectories(
    errors: ErrorParams, calibration: Calibration | None, cfg: StudyConfig | None = None, seed: int | None = None
) -> list[dict]:
    """One cw and one ccw run with their true and odometry trajectories, for figures.

    Parameters
    ----------
    errors : ErrorParams
        The robot's true errors.
    calibration : Calibration or None
        The calibration its odometry runs with.
    cfg : StudyConfig, optional
        The study (geometry, side, noise, motion).
    seed : int, optional
        Seed of the runs (default: ``cfg.seed``).

    Returns
    -------
    list of dict
        Two dicts (cw, ccw) with ``true_x``, ``true_y``, ``odo_x``, ``odo_y`` (metres, from the
        start) and ``label``: the input of :func:`umbmark.viz.plots.exaggerated_trajectory_figure`.
    """
    cfg = cfg or StudyConfig()
    seed = int(cfg.seed if seed is None else seed)
    tp = errors.true_params(cfg.geometry)
    mp = OdometryParams.from_geometry(cfg.geometry, calibration)
    out = []
    for di, direction in enumerate(("cw", "ccw")):
        ss = np.random.SeedSequence(seed, spawn_key=(_TRAJ_KEY, di))
        res = run_program(
            square_program(direction, cfg.side_m),
            tp,
            mp,
            1,
            cfg.noise,
            cfg.motion,
            rngs=run_seeds(ss, 1),
            trajectory=True,
        )
        assert res.trajectory is not None  # asked for with trajectory=True
        t: dict[str, NDArray[np.float64] | str] = {k: np.concatenate([[0.0], v[0]]) for k, v in res.trajectory.items()}
        t["label"] = direction
        out.append(t)
    return out
