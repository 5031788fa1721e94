"""The fleet: every recording of every robot self-calibrated in parallel (on a Dask cluster or
local processes) and recorded once in one history.

* :mod:`umbmark.fleet.plan`: the jobs (a recording of a robot each) of a fleet folder or a
  manifest, each with its content hash and its date (the file's time);
* :mod:`umbmark.fleet.run`: the jobs calibrated on the workers
  (:func:`~umbmark.realrobot.selfcal_settings.selfcal_recordings`, the self-calibration of
  ``umbmark selfcal``) and recorded here, each once.

A layer above :mod:`umbmark.realrobot` and :mod:`umbmark.history`; the command line
(``umbmark fleet``) parses the options, calls :func:`run_fleet` and prints what it returns.
"""

from umbmark.fleet.plan import RECORDING_SUFFIXES, FleetJob, plan_fleet, read_manifest
from umbmark.fleet.run import (
    DASK_MISSING,
    FleetOutcome,
    FleetSummary,
    JobResult,
    calibrate_job,
    check_scheduler,
    require_dask,
    run_fleet,
)

__all__ = [
    "DASK_MISSING",
    "FleetJob",
    "FleetOutcome",
    "FleetSummary",
    "JobResult",
    "RECORDING_SUFFIXES",
    "calibrate_job",
    "check_scheduler",
    "plan_fleet",
    "read_manifest",
    "require_dask",
    "run_fleet",
]
