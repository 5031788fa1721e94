"""umbmark: measure and correct the systematic odometry errors of differential-drive robots.

The main entry points, loaded when first used (``import umbmark`` itself stays light)::

    import umbmark

    runs = umbmark.simulate_umbmark(umbmark.ErrorParams(ed=1.002, eb=0.99), seed=1)
    a = umbmark.analyze(runs, side_m=4.0, wheelbase_m=0.340, method="exact")
    print(a.correction.calibration)

Layers, lowest first (each imports only lower ones):

* :mod:`umbmark.model`: geometry, error parameters, calibration types, odometry, simulation
* :mod:`umbmark.kinds`: the kinds of robot (differential drive, tricycle, mecanum), one module each
* :mod:`umbmark.metrics`: the UMBmark figures of a runs table
* :mod:`umbmark.io`: readers and writers (runs CSV, logs, bags, export)
* :mod:`umbmark.correct`: the correction methods behind one interface (bf, exact, lsq)
* :mod:`umbmark.realrobot`: replay of real logs, measurement from walls
* :mod:`umbmark.history`: the calibration history per robot
* :mod:`umbmark.viz`: figures and HTML reports
* :mod:`umbmark.studies`: the paper's reproduction, accuracy and speed benchmarks, the demo
* :mod:`umbmark.cli`: the command line
"""

from __future__ import annotations

from umbmark._lazy import lazy_names
from umbmark._version import __version__
from umbmark.errors import CorrectionUndefined, InputError, UmbmarkError

# public name -> module that defines it
_LAZY = {
    "Geometry": "umbmark.model.geometry",
    "ErrorParams": "umbmark.model.geometry",
    "Calibration": "umbmark.model.geometry",
    "OdometryParams": "umbmark.model.geometry",
    "LABMATE": "umbmark.model.geometry",
    "RunsTable": "umbmark.model.runs",
    "WheelGeometry": "umbmark.model.geometry",
    "Dataset": "umbmark.model.dataset",
    "Run": "umbmark.model.dataset",
    "integrate": "umbmark.model.odometry",
    "NoiseModel": "umbmark.model.simulate",
    "Motion": "umbmark.model.simulate",
    "noise_preset": "umbmark.model.simulate",
    "square_program": "umbmark.model.simulate",
    "run_program": "umbmark.model.simulate",
    "simulate_umbmark": "umbmark.model.simulate",
    "simulate_batch": "umbmark.model.batch",
    "UMBmarkResult": "umbmark.metrics",
    "CorrectionResult": "umbmark.correct.result",
    "correct_runs": "umbmark.correct.registry",
    "Analysis": "umbmark.correct.analysis",
    "analyze": "umbmark.correct.analysis",
    "read_runs_csv": "umbmark.io.runs_csv",
    "write_runs_csv": "umbmark.io.runs_csv",
    "load_logs": "umbmark.io.load",
    "replay_report": "umbmark.realrobot.replay",
    "open_history": "umbmark.history",
    "Intervals": "umbmark.model.intervals",
    "intervals_from_motion": "umbmark.model.intervals",
    "read_intervals_csv": "umbmark.io.intervals_csv",
    "selfcal": "umbmark.correct.selfcal",
    "SelfcalResult": "umbmark.correct.selfcal",
}

__all__ = ["__version__", "UmbmarkError", "InputError", "CorrectionUndefined", *_LAZY]

__getattr__, __dir__ = lazy_names("umbmark", _LAZY, globals())
