"""Studies built on the layers below: the paper's reproduction (:mod:`~umbmark.studies.reproduce`,
its page :mod:`~umbmark.studies.reproduce_report`), the accuracy benchmark against the
information bound (:mod:`~umbmark.studies.accuracy`), the speed benchmark
(:mod:`~umbmark.studies.speed`, with the per-sample oracle :mod:`~umbmark.studies.reference`),
the iterated calibration (:mod:`~umbmark.studies.iterate`), the demo
(:mod:`~umbmark.studies.demo`), the lidar self-calibration on real logs
(:mod:`~umbmark.studies.slam2d`), simulated tricycle and mecanum robots
(:mod:`~umbmark.studies.kinematic`) and sweeps over a process pool or a Dask cluster
(:mod:`~umbmark.studies.sweep`).

The names below and the submodules are loaded when first used.
"""

from __future__ import annotations

from umbmark._lazy import lazy_names

_LAZY = {
    "StudyConfig": "umbmark.studies.reproduce",
    "Study": "umbmark.studies.reproduce",
    "run_study": "umbmark.studies.reproduce",
    "AccuracyConfig": "umbmark.studies.accuracy",
    "run_accuracy": "umbmark.studies.accuracy",
    "calibrate_loop": "umbmark.studies.iterate",
    "compose_passes": "umbmark.studies.iterate",
    "LoopResult": "umbmark.studies.iterate",
    "demo": "umbmark.studies.demo",
    "DemoResult": "umbmark.studies.demo",
    "study_log": "umbmark.studies.slam2d",
    "Slam2dStudy": "umbmark.studies.slam2d",
}
_SUBMODULES = ("accuracy", "demo", "iterate", "reference", "reproduce", "reproduce_report", "slam2d", "speed", "sweep")

__all__ = [*_LAZY, *_SUBMODULES]

__getattr__, __dir__ = lazy_names("umbmark.studies", _LAZY, globals(), _SUBMODULES)
