"""Iterated calibration (issue 7): the simulator loop and the composition of successive passes.

* :func:`calibrate_loop` (simulator): run the bi-directional test, stop if the 3 x SEM rule says
  a further pass is unlikely to help (``E_max,syst < 3 SEM``; noise-free: ``E_max,syst <
  tol``), otherwise correct, load the correction into the robot's odometry and run again; at
  most ``max_passes`` corrections. Every pass uses fresh seeds.
* :func:`compose_passes` (real robots): runs files of successive passes, where pass k was made
  with the calibration computed from passes 1..k-1 loaded into the odometry; each pass is
  corrected relative to the odometry it ran with and composed (``E_d,total = E_d,1 E_d,2 ...``,
  ``b = b_1 E_b,2 ...``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from umbmark.correct import CorrectionResult, correct_runs
from umbmark.errors import InputError
from umbmark.metrics import UMBmarkResult, umbmark
from umbmark.model.geometry import LABMATE, Calibration, ErrorParams, Geometry
from umbmark.model.runs import RunsTable
from umbmark.model.simulate import Motion, NoiseModel, simulate_umbmark

__all__ = ["Pass", "LoopResult", "calibrate_loop", "compose_passes", "history_fields"]


@dataclass(frozen=True)
class Pass:
    """One pass: the runs made with ``calibration_used`` and what was decided from them."""

    index: int
    runs: RunsTable
    result: UMBmarkResult
    calibration_used: Calibration | None
    wheelbase_used_m: float
    correction: CorrectionResult | None  # None: no correction computed from these runs
    decision: str
    source: str | None = None

    def to_dict(self) -> dict:
        cal = self.calibration_used or Calibration()
        d = {
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
        return d


@dataclass(frozen=True)
class LoopResult:
    passes: list = field(default_factory=list)
    final_calibration: Calibration | None = None
    nominal_wheelbase_m: float = LABMATE.wheelbase_m
    stopped: str = ""
    errors: ErrorParams | None = None  # true errors (simulator only)

    @property
    def corrections(self) -> int:
        return sum(1 for p in self.passes if p.correction is not None)

    def to_dict(self) -> dict:
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
    """Simulate: run, correct, re-run until the 3 x SEM rule says stop (at most ``max_passes``
    corrections). ``tol_m``: also stop when E_max,syst is below this (noise-free runs have
    SEM = 0, so the rule alone would never stop). ``on_progress(done, total)``: called after
    each simulated test (``total`` is the most there can be, ``max_passes + 1``)."""
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
        res = umbmark(runs)
        if on_progress is not None:
            on_progress(k + 1, max_passes + 1)
        b_used = geometry.wheelbase_m if cal is None or cal.wheelbase_m is None else cal.wheelbase_m
        rule = res.sem_rule
        if res.emax_syst < tol_m:
            decision = stopped = f"stop: E_max,syst {res.emax_syst * 1e3:.3g} mm is below the tolerance"
        elif not res.second_pass_recommended:
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
    return LoopResult(passes, cal, geometry.wheelbase_m, stopped, errors)


def compose_passes(
    runs_list,
    side_m: float,
    wheelbase_m: float,
    method: str = "exact",
    prior: Calibration | None = None,
    sources=None,
    **options,
) -> LoopResult:
    """Real robots: successive passes, pass k made with the calibration from passes 1..k-1.

    ``wheelbase_m``: the wheelbase the odometry used in pass 1 (nominal); ``prior``: the
    correction factors of pass 1 (``None``: none)."""
    if not runs_list:
        raise InputError("no runs files given")
    if not (isinstance(wheelbase_m, (int, float)) and math.isfinite(wheelbase_m) and wheelbase_m > 0):
        raise InputError(f"wheelbase must be a positive length, got {wheelbase_m!r}")
    sources = list(sources) if sources is not None else [None] * len(runs_list)
    cal = prior
    passes = []
    for k, runs in enumerate(runs_list):
        b_used = wheelbase_m if cal is None or cal.wheelbase_m is None else cal.wheelbase_m
        res = umbmark(runs)
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
    return LoopResult(passes, cal, wheelbase_m, stopped, None)


def history_fields(loop: LoopResult, method: str) -> dict:
    """The fields of a calibration-history record (:func:`umbmark.history.record_result`) for a
    loop: ``kind="calibrate"``; the recommended parameters are the final (composed) calibration
    (``Eb`` relative to the wheelbase of pass 1); ``results["emax_syst_mm"]`` is pass 1's (the
    odometry as the robot ran before these calibrations), ``emax_syst_last_pass_mm`` the last
    pass's; ``parameters_in_use`` are pass 1's. The runs of every pass go into ``inputs``."""
    from umbmark.history import runs_to_rows

    first, last = loop.passes[0], loop.passes[-1]
    b0 = first.wheelbase_used_m
    cal = loop.final_calibration or Calibration()
    b = cal.wheelbase_m if cal.wheelbase_m is not None else b0
    used = first.calibration_used or Calibration()
    results = loop.to_dict()
    results["method"] = method
    results["emax_syst_mm"] = first.result.emax_syst * 1e3
    results["emax_syst_last_pass_mm"] = last.result.emax_syst * 1e3
    return {
        "kind": "calibrate",
        "method": method,
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
