"""Iterated calibration: the simulator loop and the composition of successive passes.

* :func:`calibrate_loop` (simulator): run the bi-directional test, stop if the 3 x SEM rule says
  a further pass is unlikely to help (``E_max,syst < 3 SEM``; noise-free: ``E_max,syst <
  tol``), otherwise correct, load the correction into the robot's odometry and run again; at
  most ``max_passes`` corrections. Every pass uses fresh seeds.
* :func:`compose_passes` (real robots): runs files of successive passes, where pass k was made
  with the calibration computed from passes 1..k-1 loaded into the odometry; each pass is
  corrected relative to the odometry it ran with and composed (``E_d,total = E_d,1 E_d,2 ...``,
  ``b = b_1 E_b,2 ...``).
* :func:`history_fields`: the calibration-history record of either.

The results are dataclasses in SI units (:class:`LoopResult` of :class:`Pass`); their
``to_dict()`` is the JSON of ``umbmark calibrate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from umbmark._files import same_inputs
from umbmark.correct import CorrectionResult, correct_runs
from umbmark.errors import InputError
from umbmark.metrics import UMBmarkResult, umbmark_figures
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import Motion, NoiseModel, simulate_umbmark

__all__ = ["Pass", "Simulation", "LoopResult", "calibrate_loop", "compose_passes", "history_fields"]


@dataclass(frozen=True)
class Pass:
    """One pass: the runs made with ``calibration_used`` and what was decided from them.

    Attributes
    ----------
    index : int
        1 for the first pass.
    runs : RunsTable
        The pass's runs.
    result : UMBmarkResult
        Their UMBmark figures.
    calibration_used : Calibration or None
        The correction the odometry ran with (None: the nominal odometry).
    wheelbase_used_m : float
        The wheelbase the odometry ran with.
    correction : CorrectionResult or None
        The correction computed from these runs (None: none was).
    decision : str
        What was decided, in words.
    source : str or None
        The runs file of the pass.
    """

    index: int
    runs: RunsTable
    result: UMBmarkResult
    calibration_used: Calibration | None
    wheelbase_used_m: float
    correction: CorrectionResult | None
    decision: str
    source: str | None = None

    def to_dict(self) -> dict:
        """The pass as JSON (mm)."""
        cal = self.calibration_used or Calibration()
        return {
            "pass": self.index,
            "source": self.source,
            "calibration_used": {
                "c_left": cal.c_left,
                "c_right": cal.c_right,
                "wheelbase_mm": self.wheelbase_used_m * 1e3,
            },
            "emax_syst_mm": self.result.emax_syst * 1e3,
            "three_sem_mm": None if self.result.sem_rule is None else self.result.sem_rule * 1e3,
            "second_pass_recommended": self.result.second_pass_recommended,
            "decision": self.decision,
            "correction": None if self.correction is None else self.correction.to_dict(),
        }


@dataclass(frozen=True)
class Simulation:
    """The settings of a simulated calibration loop.

    Attributes
    ----------
    runs_per_direction : int
        Runs per direction in each pass.
    noise : str
        The noise model's name.
    seed : int
        The seed of the loop.
    sample_period_s : float or None
        The odometry's sampling period (None: exact arcs).
    max_passes : int
        The most corrections the loop may make.
    side_m : float
        The side of the square.
    """

    runs_per_direction: int
    noise: str
    seed: int
    sample_period_s: float | None
    max_passes: int
    side_m: float


@dataclass(frozen=True)
class LoopResult:
    """Successive passes and the calibration they lead to.

    Attributes
    ----------
    passes : list of Pass
        The passes, first to last.
    final_calibration : Calibration or None
        The composed calibration to load (None: no correction was made).
    nominal_wheelbase_m : float
        The wheelbase of pass 1's odometry.
    stopped : str
        Why the loop stopped, or what to do next.
    errors : ErrorParams or None
        The simulated robot's true errors (None for a real robot's passes).
    method : str
        The correction method.
    simulation : Simulation or None
        The simulator's settings (None for a real robot's passes).
    """

    passes: list = field(default_factory=list)
    final_calibration: Calibration | None = None
    nominal_wheelbase_m: float = LABMATE.wheelbase_m
    stopped: str = ""
    errors: ErrorParams | None = None
    method: str = "exact"
    simulation: Simulation | None = None

    @property
    def corrections(self) -> int:
        """The number of passes a correction was computed from."""
        return sum(1 for p in self.passes if p.correction is not None)

    def to_dict(self) -> dict:
        """The JSON of ``umbmark calibrate --json``: the passes, the final calibration (mm), the
        true errors of a simulated robot and the method."""
        cal = self.final_calibration or Calibration()
        d = {
            "passes": [p.to_dict() for p in self.passes],
            "corrections": self.corrections,
            "stopped": self.stopped,
            "final_calibration": {
                "c_left": cal.c_left,
                "c_right": cal.c_right,
                "Ed": cal.ed,
                "wheelbase_mm": (cal.wheelbase_m or self.nominal_wheelbase_m) * 1e3,
            },
        }
        if self.errors is not None:
            d["true"] = {
                "Ed": self.errors.ed,
                "Eb": self.errors.eb,
                "Es": self.errors.es,
                "wheelbase_mm": self.errors.eb * self.nominal_wheelbase_m * 1e3,
            }
        d["method"] = self.method
        return d


def calibrate_loop(
    errors: ErrorParams,
    geometry: Geometry = LABMATE,
    side_m: float = 4.0,
    n_runs: int = 5,
    noise: NoiseModel | str = "paper",
    motion: Motion | None = None,
    method: str = "exact",
    max_passes: int = 3,
    seed: int = 0,
    prior: Calibration | None = None,
    tol_m: float = 1e-5,
    on_progress=None,
    **options,
) -> LoopResult:
    """Simulate the calibration loop: run, correct, re-run until the 3 x SEM rule says stop.

    Every pass draws fresh seeds from ``seed``; pass k runs with the correction of pass k-1
    loaded into the robot's odometry.

    Parameters
    ----------
    errors : ErrorParams
        The simulated robot's true errors.
    geometry : Geometry
        Its nominal geometry (what the odometry starts from).
    side_m : float
        The side of the square.
    n_runs : int
        Runs per direction in each pass (at least 2).
    noise : NoiseModel or str
        The non-systematic errors (a preset's name or a model).
    motion : Motion, optional
        The motion and sampling of the runs.
    method : str
        The correction method.
    max_passes : int
        At most this many corrections (at least 1).
    seed : int
        The loop's seed.
    prior : Calibration, optional
        The correction the odometry runs with in pass 1 (None: the nominal odometry).
    tol_m : float
        Also stop when E_max,syst is below this (noise-free runs have SEM = 0, so the rule
        alone would never stop).
    on_progress : callable, optional
        ``on_progress(done, total)`` after each simulated test (``total``: the most there can
        be, ``max_passes + 1``).
    **options
        Options of the correction method.

    Returns
    -------
    LoopResult
        With the true errors and the simulation's settings.

    Raises
    ------
    InputError
        Fewer than 2 runs per direction or 1 pass; bad simulation or correction input.
    """
    if max_passes < 1:
        raise InputError(f"the number of passes must be >= 1, got {max_passes}")
    if n_runs < 2:
        raise InputError("the 3 x SEM rule needs at least 2 runs per direction")
    cal = prior
    seeds = np.random.SeedSequence(seed).spawn(max_passes + 1)
    passes: list[Pass] = []
    stopped = ""
    for k in range(max_passes + 1):
        runs = simulate_umbmark(errors, geometry, side_m, n_runs, cal, noise, motion, seed=seeds[k])
        res = umbmark_figures(runs)
        if on_progress is not None:
            on_progress(k + 1, max_passes + 1)
        b_used = geometry.wheelbase_m if cal is None or cal.wheelbase_m is None else cal.wheelbase_m
        rule = res.sem_rule
        if res.emax_syst < tol_m:
            decision = stopped = f"stop: E_max,syst {res.emax_syst * 1e3:.3g} mm is below the tolerance"
        elif not res.second_pass_recommended:
            assert rule is not None  # a further pass is recommended whenever the spread is unknown
            decision = stopped = (
                f"stop: E_max,syst {res.emax_syst * 1e3:.1f} mm < 3 x SEM = {rule * 1e3:.1f} mm "
                "(a further pass is unlikely to help)"
            )
        elif k == max_passes:
            decision = stopped = f"stop: {max_passes} correction passes done (E_max,syst still >= 3 x SEM)"
        else:
            decision = ""
        if decision:
            passes.append(Pass(k + 1, runs, res, cal, b_used, None, decision))
            break
        corr = correct_runs(method, runs, side_m, b_used, cal, **options)
        passes.append(
            Pass(
                k + 1,
                runs,
                res,
                cal,
                b_used,
                corr,
                f"correct ({method}): E_max,syst {res.emax_syst * 1e3:.1f} mm"
                + ("" if rule is None else f" >= 3 x SEM = {rule * 1e3:.1f} mm"),
            )
        )
        cal = corr.calibration
    name = noise if isinstance(noise, str) else noise.name
    period = (motion or Motion()).sample_period_s
    sim = Simulation(n_runs, name, seed, period, max_passes, side_m)
    return LoopResult(passes, cal, geometry.wheelbase_m, stopped, errors, method, sim)


def compose_passes(
    runs_list,
    side_m: float,
    wheelbase_m: float,
    method: str = "exact",
    prior: Calibration | None = None,
    sources=None,
    **options,
) -> LoopResult:
    """A real robot's successive passes, pass k made with the calibration from passes 1..k-1.

    Each pass is corrected relative to the odometry it ran with and the corrections are
    composed.

    Parameters
    ----------
    runs_list : sequence of RunsTable
        The runs of each pass, first to last.
    side_m : float
        The side of the square.
    wheelbase_m : float
        The wheelbase the odometry used in pass 1 (nominal).
    method : str
        The correction method.
    prior : Calibration, optional
        The correction factors of pass 1 (None: none).
    sources : sequence of str, optional
        The runs file of each pass (named in errors; hashed in the history record).
    **options
        Options of the correction method.

    Returns
    -------
    LoopResult

    Raises
    ------
    InputError
        No passes, a bad wheelbase, runs a pass's correction cannot use (its file named).
    """
    if not runs_list:
        raise InputError("no runs files given")
    if not (isinstance(wheelbase_m, (int, float)) and math.isfinite(wheelbase_m) and wheelbase_m > 0):
        raise InputError(f"wheelbase must be a positive length, got {wheelbase_m!r}")
    sources = list(sources) if sources is not None else [None] * len(runs_list)
    files = [s_ for s_ in sources if s_ is not None and Path(s_).exists()]
    same = same_inputs(files)
    if same:
        first, again = same[0]
        raise InputError(
            f"{again} is the same runs file as {first}: each pass is driven with the correction of the passes "
            "before it, so one test given twice would apply its correction twice; give each pass's file once"
        )
    cal = prior
    passes = []
    for k, runs in enumerate(runs_list):
        b_used = wheelbase_m if cal is None or cal.wheelbase_m is None else cal.wheelbase_m
        res = umbmark_figures(runs)
        try:
            corr = correct_runs(method, runs, side_m, b_used, cal, **options)
        except InputError as e:
            if sources[k] is not None and e.source is None:
                raise InputError(str(e), source=sources[k]) from None
            raise
        rule = res.sem_rule
        note = "" if res.second_pass_recommended else " (E_max,syst < 3 x SEM: this pass was probably not needed)"
        passes.append(
            Pass(
                k + 1,
                runs,
                res,
                cal,
                b_used,
                corr,
                f"correct ({method}): E_max,syst {res.emax_syst * 1e3:.1f} mm"
                + ("" if rule is None else f", 3 x SEM = {rule * 1e3:.1f} mm")
                + note,
                sources[k],
            )
        )
        cal = corr.calibration
    last = passes[-1].result
    stopped = (
        "load the final calibration and run the test again to check it"
        if last.second_pass_recommended
        else "the last pass was already below 3 x SEM: the final calibration is as good as these runs allow"
    )
    return LoopResult(passes, cal, wheelbase_m, stopped, None, method)


def _runs_files_fields(sources: list[str]) -> dict:
    """The hashes of the runs files of the passes: ``runs_files`` (path and SHA-256 of each),
    ``input_sha256`` (one file: its hash; several: the hash of their hashes, in pass order) and
    ``source`` (the last pass's file)."""
    from umbmark._files import file_sha256, inputs_sha256

    shas = [file_sha256(f) for f in sources]
    return {
        "runs_files": [{"path": str(Path(f).resolve()), "sha256": h} for f, h in zip(sources, shas)],
        "input_sha256": inputs_sha256(sources),
        "source": str(Path(sources[-1]).resolve()),
    }


def history_fields(loop: LoopResult) -> dict:
    """The calibration-history record of a loop.

    Parameters
    ----------
    loop : LoopResult
        A simulated loop or a real robot's passes.

    Returns
    -------
    dict
        The keyword arguments of :func:`umbmark.history.record_result` (without ``robot`` and
        ``db``): ``kind="calibrate"``; the recommended ``parameters`` are the final (composed)
        calibration (``Eb`` relative to the wheelbase of pass 1); ``results`` is the loop's
        JSON with ``emax_syst_mm`` of pass 1 (the odometry as the robot ran before these
        calibrations) and ``emax_syst_last_pass_mm``; ``parameters_in_use`` are pass 1's. The
        runs of every pass go into ``inputs``, with the simulator's settings, or the runs
        files of a real robot's passes (their SHA-256 in ``input_sha256``, the last one as
        ``source``).
    """
    from umbmark.history import runs_to_rows

    first, last = loop.passes[0], loop.passes[-1]
    b0 = first.wheelbase_used_m
    cal = loop.final_calibration or Calibration()
    b = cal.wheelbase_m if cal.wheelbase_m is not None else b0
    used = first.calibration_used or Calibration()
    results = loop.to_dict()
    results["emax_syst_mm"] = first.result.emax_syst * 1e3
    results["emax_syst_last_pass_mm"] = last.result.emax_syst * 1e3
    fields: dict[str, Any] = {
        "kind": "calibrate",
        "method": loop.method,
        "results": results,
        "parameters": {
            "c_left": cal.c_left,
            "c_right": cal.c_right,
            "wheelbase_mm": b * 1e3,
            "Ed": cal.ed,
            "Eb": b / b0,
        },
        "parameters_in_use": {"c_left": used.c_left, "c_right": used.c_right, "wheelbase_mm": b0 * 1e3},
        "inputs": {"passes": [{"source": p.source, "runs": runs_to_rows(p.runs)} for p in loop.passes]},
    }
    sim = loop.simulation
    if sim is not None:
        e = loop.errors
        assert e is not None  # a simulated loop carries its robot's true errors
        fields["inputs"]["simulation"] = {
            "Ed": e.ed,
            "Eb": e.eb,
            "runs_per_direction": sim.runs_per_direction,
            "noise": sim.noise,
            "seed": sim.seed,
            "sample_period_ms": None if sim.sample_period_s is None else sim.sample_period_s * 1e3,
            "max_passes": sim.max_passes,
            "side_mm": sim.side_m * 1e3,
        }
        fields["note"] = "simulated robot"
    elif all(p.source is not None for p in loop.passes):
        files = _runs_files_fields([p.source for p in loop.passes])
        fields["inputs"]["runs_files"] = files.pop("runs_files")
        fields.update(files)
    return fields
