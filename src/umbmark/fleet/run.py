"""A fleet's jobs self-calibrated on a Dask cluster (or local processes) into one history, each
recording once, dated when its file was last written.

Each job runs on a worker (:func:`calibrate_job`: the self-calibration of ``umbmark selfcal``,
:func:`~umbmark.realrobot.selfcal_settings.selfcal_recordings`); the results come back to this
process, which alone writes the history. A recording whose content (SHA-256) the robot's history
holds is skipped before it is sent, and the history itself refuses a second record of one
recording (:class:`~umbmark.history.SameRecording`, checked in the transaction of the insert):
of two fleets recording one recording at once into one history, one records it and the other
finds it recorded. A job a lost worker had
is run again by the scheduler and recorded once. A recording that fails, or whose file time
cannot date a record (in the future, before 1970), is reported by name and the others go on. At
most ``2 x workers`` jobs are in flight, so memory stays bounded however many recordings there
are. A local cluster keeps its scratch files in a temporary folder it removes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from umbmark.errors import InputError, UmbmarkError
from umbmark.fleet.plan import FleetJob

__all__ = [
    "DASK_MISSING",
    "FleetOutcome",
    "FleetSummary",
    "JobResult",
    "calibrate_job",
    "check_scheduler",
    "require_dask",
    "run_fleet",
]

DASK_MISSING = (
    "the fleet runs on Dask, which is not installed here: pip install 'umbmark[dask]' "
    "(in a checkout of umbmark: pip install -e '.[dask]')"
)
"""What to install for the fleet."""

STATUSES = ("recorded", "skipped", "failed")
"""What becomes of a job."""

_SET_THE_TIME = "a clock set wrong? set the file's time to when it was recorded (touch -d TIME FILE)"


@dataclass(frozen=True)
class FleetOutcome:
    """What became of one job: recorded (its record id), skipped (already recorded) or failed
    (why, in one line)."""

    robot: str
    path: str
    status: str
    record_id: int | None = None
    error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "robot": self.robot,
            "path": self.path,
            "status": self.status,
            "record_id": self.record_id,
            "error": self.error,
        }


@dataclass
class FleetSummary:
    """Every job's outcome, in the order they finished."""

    outcomes: list[FleetOutcome] = field(default_factory=list)

    def count(self, status: str) -> int:
        return sum(o.status == status for o in self.outcomes)

    def to_dict(self) -> dict[str, Any]:
        return {
            "recordings": len(self.outcomes),
            "recorded": self.count("recorded"),
            "skipped": self.count("skipped"),
            "failed": self.count("failed"),
            "outcomes": [o.to_dict() for o in self.outcomes],
        }


@dataclass(frozen=True)
class JobResult:
    """What a worker sends back for one job: the keyword arguments of its record
    (:meth:`~umbmark.realrobot.selfcal.SelfcalReport.history_fields`), or why it failed."""

    fields: dict[str, Any] | None = None
    error: str | None = None


def calibrate_job(job: FleetJob) -> JobResult:
    """On a worker: the self-calibration of one job's recording with its settings.

    Parameters
    ----------
    job : FleetJob
        With :attr:`~FleetJob.settings`.

    Returns
    -------
    JobResult
        The record's fields, or the one-line reason it failed (bad input, an unreadable file).
    """
    from umbmark.realrobot.kinematic_settings import KinematicSettings, kinematic_recordings
    from umbmark.realrobot.selfcal_settings import selfcal_recordings

    if job.settings is None:
        return JobResult(error="no settings for its self-calibration")
    try:
        if isinstance(job.settings, KinematicSettings):  # a robot of another kind than a differential drive
            report: Any = kinematic_recordings([job.path], job.settings)
        else:
            report = selfcal_recordings([job.path], job.settings)
        return JobResult(fields=report.history_fields(kind="selfcal"))
    except UmbmarkError as e:
        return JobResult(error=str(e))
    except OSError as e:
        return JobResult(error=f"{e.strerror or type(e).__name__}: {e.filename or job.path}")


def require_dask() -> None:
    """Raise :class:`InputError` saying what to install when Dask's ``distributed`` is missing."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise InputError(DASK_MISSING) from None


def _masked(address: str) -> str:
    """An address with whatever stands before its host's ``@`` (a user name, a password) masked."""
    scheme, sep, rest = address.rpartition("://") if "://" in address else ("", "", address)
    host = rest.split("/", 1)[0]
    if "@" not in host:
        return address
    return f"{scheme}{sep}***@{host.rpartition('@')[2]}{rest[len(host) :]}"


def check_scheduler(dask: Any) -> None:
    """Refuse a scheduler that is neither ``"local"`` nor an address (``tcp://host:8786``), and
    an address holding a user name or password (masked in the message).

    Raises
    ------
    InputError
    """
    if not isinstance(dask, str) or dask == "local":
        return
    scheme, sep, rest = dask.partition("://")
    host = rest.split("/", 1)[0]
    if "@" in host or (not sep and "@" in dask):
        raise InputError(
            f"the Dask scheduler's address {_masked(dask)} holds a user name or password, which Dask does not take "
            "(it secures a connection with TLS certificates: tls://host:8786 and Dask's security settings)"
        )
    if not sep or not scheme or not host:
        raise InputError(f"the scheduler is an address such as tcp://host:8786 or 'local', got {dask!r}")


def _client(dask: Any, workers: int, stack: ExitStack) -> Any:
    """The Dask client: the one given, a local cluster's (its scratch folder removed after it),
    or a scheduler's; closed by ``stack``."""
    from distributed import Client, LocalCluster

    if not isinstance(dask, str):
        return dask
    if dask == "local":
        import tempfile

        import dask as dask_

        scratch = stack.enter_context(tempfile.TemporaryDirectory(prefix="umbmark-fleet-", ignore_cleanup_errors=True))
        stack.enter_context(dask_.config.set({"temporary-directory": scratch}))
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # no dashboard; its HTTP server on a free port (another fleet's may hold 8787)
            scheduler_kwargs={"dashboard": False},
            local_directory=scratch,
        )
        stack.callback(cluster.close)
        client = Client(cluster)
        stack.callback(client.close)
        return client
    try:
        client = Client(dask, timeout="10s")
    except Exception as e:  # noqa: BLE001  whatever the connection raises is one line naming the scheduler
        raise InputError(f"cannot reach the Dask scheduler at {dask}: {type(e).__name__}: {e}") from None
    stack.callback(client.close)
    return client


def run_fleet(
    jobs: Sequence[FleetJob],
    db: str | Path,
    *,
    dask: Any = "local",
    workers: int = 2,
    on_outcome: Callable[[FleetOutcome, int, int], None] | None = None,
) -> FleetSummary:
    """Self-calibrate the jobs on a Dask cluster and record each result in the history.

    Parameters
    ----------
    jobs : sequence of FleetJob
        Each with its :attr:`~FleetJob.settings`.
    db : str or Path
        The history (a file or a database URL; PostgreSQL for a fleet of writers).
    dask : str or distributed.Client
        ``"local"`` (a local cluster of ``workers`` processes), a scheduler address
        (``tcp://host:8786``) or a client.
    workers : int
        The local cluster's processes (and twice this, the jobs in flight).
    on_outcome : callable, optional
        Told each outcome with the count done and the total.

    Returns
    -------
    FleetSummary

    Raises
    ------
    InputError
        Dask not installed (:data:`DASK_MISSING`), a bad scheduler address, a job without
        settings, a scheduler that cannot be reached.
    """
    from umbmark.history import open_history

    require_dask()
    check_scheduler(dask)
    unset = [j for j in jobs if j.settings is None]
    if unset:
        raise InputError(f"{unset[0].path}: no self-calibration settings (`settings`) for robot {unset[0].robot!r}")
    summary = FleetSummary()
    total = len(jobs)

    def done(o: FleetOutcome) -> None:
        summary.outcomes.append(o)
        if on_outcome is not None:
            on_outcome(o, len(summary.outcomes), total)

    with open_history(db) as h:
        todo = _to_send(h, jobs, done)
        if todo:
            _run(todo, lambda j, r: _record(h, j, r), dask, workers, done)
    return summary


def _to_send(history: Any, jobs: Sequence[FleetJob], done: Callable[[FleetOutcome], None]) -> list[FleetJob]:
    """The jobs to calibrate: not those the history holds (nor a second of one recording of a
    robot), nor those whose file time cannot date a record (failed here)."""
    from datetime import datetime

    from umbmark.history.base import session_time_problem

    known = set()
    for robot in {j.robot for j in jobs}:
        known |= {(robot, r.input_sha256) for r in history.records(robot) if r.input_sha256}
    todo = []
    for j in jobs:
        key = (j.robot, j.sha256)
        problem = None if j.when is None else session_time_problem(datetime.fromisoformat(j.when))
        if key in known:
            done(FleetOutcome(j.robot, j.path, "skipped"))
        elif problem is not None:
            why = f"its file's time {j.when} {problem}, and a record is dated by it: {_SET_THE_TIME}"
            done(FleetOutcome(j.robot, j.path, "failed", error=why))
        else:
            known.add(key)
            todo.append(j)
    return todo


def _record(history: Any, job: FleetJob, result: JobResult) -> FleetOutcome:
    """A worker's result into the history (once per recording and robot)."""
    from umbmark.history import SameRecording

    if result.fields is None:
        return FleetOutcome(job.robot, job.path, "failed", error=str(result.error))
    fields = {**result.fields, "input_sha256": job.sha256, "source": job.path, "when": job.when}
    try:
        return FleetOutcome(job.robot, job.path, "recorded", int(history.add(job.robot, **fields)))
    except SameRecording:
        return FleetOutcome(job.robot, job.path, "skipped")
    except UmbmarkError as e:
        return FleetOutcome(job.robot, job.path, "failed", error=str(e))


def _run(
    todo: list[FleetJob],
    record: Callable[[FleetJob, JobResult], FleetOutcome],
    dask: Any,
    workers: int,
    done: Callable[[FleetOutcome], None],
) -> None:
    from distributed import as_completed

    with ExitStack() as stack:
        client = _client(dask, workers, stack)
        limit = max(2, 2 * workers)
        pending = list(reversed(todo))
        futures: dict[Any, FleetJob] = {}
        ac = as_completed()

        def submit() -> None:
            j = pending.pop()
            f = client.submit(calibrate_job, j, pure=False)
            futures[f.key] = j
            ac.add(f)

        while pending and len(futures) < limit:
            submit()
        for f in ac:
            j = futures.pop(f.key)
            try:
                out = f.result()
            except Exception as e:  # noqa: BLE001  a job that failed on its worker: reported by name
                out = JobResult(error=f"{type(e).__name__}: {e}")
            done(record(j, out))
            if pending:
                submit()
