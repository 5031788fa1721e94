"""A fleet's recordings calibrated in parallel (on a Dask cluster or local processes) into one
history, each recording once, dated when its file was last written.

The layout: a folder with one sub-folder per robot, holding that robot's recordings (bags, ROS 2
bag folders, intervals files); or a manifest (YAML) naming each robot's recordings. Each
recording is a job; the jobs run on the workers (a function the caller gives: the command line
runs its own ``selfcal`` on each); the results come back to this process, which alone writes the
history: a recording whose content (SHA-256) the robot's history already holds is skipped before
it is sent, and a job a lost worker had is run again by the scheduler and recorded once. A
recording that fails is reported by name and the others go on. At most ``2 x workers`` jobs are
in flight, so memory stays bounded however many recordings there are.
"""

from __future__ import annotations

import builtins
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from umbmark.errors import InputError, UmbmarkError

__all__ = ["FleetJob", "FleetOutcome", "FleetSummary", "plan_fleet", "read_manifest", "run_fleet", "RECORDING_SUFFIXES"]

# what a recording is: a bag file, an intervals file (a ROS 2 bag is a folder with metadata.yaml)
RECORDING_SUFFIXES = (".bag", ".mcap", ".db3", ".csv")


@dataclass(frozen=True)
class FleetJob:
    """One recording of one robot, with the options its calibration takes."""

    robot: str
    path: str
    sha256: str
    args: tuple[str, ...] = ()
    when: str | None = None


@dataclass(frozen=True)
class FleetOutcome:
    """What became of one job: recorded (its record id), skipped (already recorded) or failed."""

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


def _modified(p: Path) -> str:
    """When a recording was last written (a ROS 2 bag folder: its metadata), ISO 8601 UTC."""
    from datetime import datetime, timezone

    f = p / "metadata.yaml" if p.is_dir() else p
    return datetime.fromtimestamp(f.stat().st_mtime, tz=timezone.utc).isoformat()


def _recordings(folder: Path) -> list[Path]:
    """The recordings in a robot's folder: bag and intervals files, and ROS 2 bag folders."""
    out = []
    for p in sorted(folder.iterdir()):
        if p.name.startswith("."):
            continue
        if p.is_dir() and (p / "metadata.yaml").is_file():
            out.append(p)
        elif p.is_file() and p.suffix.lower() in RECORDING_SUFFIXES:
            out.append(p)
    return out


def plan_fleet(
    root: str | Path, args: Sequence[str] = (), file_hash: Callable[[str | Path], str] | None = None
) -> list[FleetJob]:
    """The jobs of a fleet folder: ``root/ROBOT/recording`` for every robot folder.

    Parameters
    ----------
    root : str or Path
        The fleet's folder.
    args : sequence of str
        The options of every job (for the worker function).
    file_hash : callable, optional
        Content hash of a recording (default :func:`umbmark.history.file_sha256`).

    Returns
    -------
    list of FleetJob

    Raises
    ------
    InputError
        The folder is missing or holds no robot folder with a recording.
    """
    from umbmark.history import check_robot, file_sha256

    h = file_hash or file_sha256
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: no such folder (a fleet folder holds one folder per robot)")
    jobs = []
    for d in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        if (d / "metadata.yaml").is_file():
            raise InputError(f"{d}: a ROS 2 bag, not a robot's folder (put the bags in {root}/ROBOT/)")
        robot = check_robot(d.name)
        jobs += [FleetJob(robot, str(p), h(p), tuple(args), _modified(p)) for p in _recordings(d)]
    if not jobs:
        raise InputError(
            f"{root}: no recordings (expected {root}/ROBOT/*.bag, *.mcap, *.db3, *.csv or ROS 2 bag folders)"
        )
    return jobs


def read_manifest(path: str | Path, file_hash: Callable[[str | Path], str] | None = None) -> list[FleetJob]:
    """The jobs of a manifest: YAML ``{robots: {NAME: {recordings: [paths], args: [options]}}}``
    (paths relative to the manifest's folder).

    Raises
    ------
    InputError
        A file that is not such a manifest, a robot without recordings, a recording missing.
    """
    import yaml

    from umbmark.history import check_robot, file_sha256

    h = file_hash or file_sha256
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise InputError(f"{path}: not a readable YAML manifest ({type(e).__name__})") from None
    robots = data.get("robots") if isinstance(data, dict) else None
    if not isinstance(robots, dict) or not robots:
        raise InputError(f"{path}: a manifest holds `robots:` mapping each robot's name to its `recordings:`")
    jobs = []
    for name, spec in robots.items():
        robot = check_robot(str(name))
        recs = spec.get("recordings") if isinstance(spec, dict) else None
        if not isinstance(recs, list) or not recs or not builtins.all(isinstance(r, str) for r in recs):
            raise InputError(f"{path}: robot {robot!r} needs `recordings:`, a list of paths")
        args = spec.get("args", [])
        if isinstance(args, str):
            args = args.split()
        if not isinstance(args, list) or not builtins.all(isinstance(a, (str, int, float)) for a in args):
            raise InputError(f"{path}: robot {robot!r}: `args:` is a list of options")
        for r in recs:
            p = (path.parent / r) if not Path(r).is_absolute() else Path(r)
            if not p.exists():
                raise InputError(f"{path}: robot {robot!r}: recording {r} does not exist")
            jobs.append(FleetJob(robot, str(p), h(p), tuple(str(a) for a in args), _modified(p)))
    return jobs


def _recorded_hashes(history: Any, robots: set[str]) -> set[tuple[str, str]]:
    known = set()
    for robot in robots:
        for r in history.records(robot):
            if r.input_sha256:
                known.add((robot, r.input_sha256))
    return known


def run_fleet(
    jobs: Sequence[FleetJob],
    calibrate: Callable[[FleetJob], dict[str, Any]],
    record: Callable[[Any, FleetJob, dict[str, Any]], int],
    db: str | Path,
    *,
    dask: Any = "local",
    workers: int = 2,
    on_outcome: Callable[[FleetOutcome, int, int], None] | None = None,
) -> FleetSummary:
    """Calibrate the jobs on a Dask cluster and record each result in the history.

    Parameters
    ----------
    jobs : sequence of FleetJob
    calibrate : callable
        Run on a worker: ``calibrate(job)`` returns ``{"ok": True, "result": ...}`` or
        ``{"ok": False, "error": "one line"}`` (picklable: a module-level function).
    record : callable
        Run here: ``record(history, job, result)`` stores a result and returns its record id.
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
    """
    from umbmark.history import open_history

    summary = FleetSummary()
    total = len(jobs)

    def done(o: FleetOutcome) -> None:
        summary.outcomes.append(o)
        if on_outcome is not None:
            on_outcome(o, len(summary.outcomes), total)

    with open_history(db) as h:
        known = _recorded_hashes(h, {j.robot for j in jobs})
        todo = []
        seen = set()
        for j in jobs:
            key = (j.robot, j.sha256)
            if key in known or key in seen:
                done(FleetOutcome(j.robot, j.path, "skipped"))
            else:
                seen.add(key)
                todo.append(j)
        if todo:
            _run(todo, calibrate, lambda j, r: record(h, j, r), dask, workers, done)
    return summary


def _client(dask: Any, workers: int) -> tuple[Any, list[Any]]:
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            'Dask is not installed: pip install -e ".[dask]" (or pip install "dask[distributed]")'
        ) from None
    if not isinstance(dask, str):
        return dask, []
    if dask == "local":
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        return client, [client, cluster]
    if "://" in dask:
        try:
            client = Client(dask, timeout="10s")
        except (OSError, TimeoutError) as e:
            raise InputError(f"cannot reach the Dask scheduler at {dask}: {e}") from None
        return client, [client]
    raise InputError(f"the scheduler is an address such as tcp://host:8786 or 'local', got {dask!r}")


def _run(
    todo: list[FleetJob],
    calibrate: Callable[[FleetJob], dict[str, Any]],
    record: Callable[[FleetJob, dict[str, Any]], int],
    dask: Any,
    workers: int,
    done: Callable[[FleetOutcome], None],
) -> None:
    from distributed import as_completed

    client, own = _client(dask, workers)
    try:
        limit = max(2, 2 * workers)
        pending = list(reversed(todo))
        futures: dict[Any, FleetJob] = {}
        ac = as_completed()
        while pending and len(futures) < limit:
            j = pending.pop()
            f = client.submit(calibrate, j, pure=False)
            futures[f.key] = j
            ac.add(f)
        for f in ac:
            j = futures.pop(f.key)
            try:
                out = f.result()
            except Exception as e:  # noqa: BLE001  a job that failed on its worker: reported by name
                out = {"ok": False, "error": f"{type(e).__name__}: {e}"}
            if out.get("ok"):
                try:
                    done(FleetOutcome(j.robot, j.path, "recorded", record(j, out["result"])))
                except UmbmarkError as e:
                    done(FleetOutcome(j.robot, j.path, "failed", error=str(e)))
            else:
                done(FleetOutcome(j.robot, j.path, "failed", error=str(out.get("error"))))
            if pending:
                nj = pending.pop()
                nf = client.submit(calibrate, nj, pure=False)
                futures[nf.key] = nj
                ac.add(nf)
    finally:
        for o in own:
            o.close()
