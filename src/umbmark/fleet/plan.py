"""The jobs of a fleet: one per recording of a robot, with the recording's content hash and
date, from a fleet folder (:func:`plan_fleet`) or a manifest (:func:`read_manifest`).

A fleet folder holds one sub-folder per robot, named as the robot, with that robot's
recordings (bags, ROS 2 bag folders, intervals files). A manifest (YAML) names each robot's
recordings and the options of its self-calibration::

    robots:
      r7:
        recordings: [bags/r7/monday.mcap, bags/r7/tuesday.mcap]
        args: [--wheel-diameter-mm, 100, --wheelbase-mm, 300]

The options stay text here (:attr:`FleetJob.args`): the front end that knows them turns them
into :class:`~umbmark.realrobot.selfcal_settings.SelfcalSettings` (:attr:`FleetJob.settings`).
"""

from __future__ import annotations

import shlex
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from umbmark.errors import InputError

if TYPE_CHECKING:
    import yaml

    from umbmark.realrobot.kinematic_settings import KinematicSettings
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

__all__ = ["FleetJob", "RECORDING_SUFFIXES", "MANIFEST_KEYS", "ROBOT_KEYS", "plan_fleet", "read_manifest"]

RECORDING_SUFFIXES = (".bag", ".mcap", ".db3", ".csv")
"""What a recording is: a bag file, an intervals file (a ROS 2 bag is a folder with metadata.yaml)."""

MANIFEST_KEYS = ("robots",)
"""The keys of a manifest."""

ROBOT_KEYS = ("recordings", "kind", "args")
"""The keys of a robot's entry in a manifest."""

MAX_MANIFEST_BYTES = 16 * 2**20
"""The largest manifest read (a fleet of thousands of robots is a few megabytes)."""


@dataclass(frozen=True)
class FleetJob:
    """One recording of one robot.

    Parameters
    ----------
    robot : str
        The robot's name (its history's).
    path : str
        The recording.
    sha256 : str
        Its content hash (:func:`umbmark.history.file_sha256`): a recording the robot's history
        holds is not calibrated again.
    args : tuple of str
        The options of its self-calibration, as given (the command line's or the manifest's).
    when : str, optional
        ISO 8601 UTC: when the recording's file was last written, the date of its record.
    origin : str, optional
        Where ``args`` were given (``MANIFEST:LINE``), for messages.
    kind : str, optional
        The robot's kind as its manifest names it (:data:`umbmark.kinds.KINDS`; None: as its
        options say, by default a differential drive).
    settings : SelfcalSettings or KinematicSettings, optional
        Its self-calibration's settings (made from ``args``; needed to run it): a differential
        drive's, or a robot's of another kind.
    """

    robot: str
    path: str
    sha256: str
    args: tuple[str, ...] = ()
    when: str | None = None
    origin: str | None = None
    settings: SelfcalSettings | KinematicSettings | None = None
    kind: str | None = None

    @property
    def is_intervals(self) -> bool:
        """An intervals file (``.csv``), not a bag."""
        return Path(self.path).suffix.lower() == ".csv"


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
        The options of every job's self-calibration.
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


class _Manifest:
    """A manifest's YAML nodes read strictly: every key once, only the known keys."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, message: str, node: yaml.Node | None = None) -> InputError:
        line = None if node is None else node.start_mark.line + 1
        return InputError(message, source=str(self.path), line=line)

    def root(self) -> yaml.Node:
        import yaml

        try:
            with open(self.path, "rb") as f:
                raw = f.read(MAX_MANIFEST_BYTES + 1)
            if len(raw) > MAX_MANIFEST_BYTES:
                raise self.fail(f"more than {MAX_MANIFEST_BYTES // 2**20} MB: not a manifest")
            node = yaml.compose(raw.decode("utf-8"), Loader=yaml.SafeLoader)
        except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
            mark = getattr(e, "problem_mark", None)
            line = None if mark is None else mark.line + 1
            raise InputError(f"not a readable YAML manifest ({type(e).__name__})", str(self.path), line) from None
        if node is None:
            raise self.fail("empty: a manifest holds `robots:` mapping each robot's name to its `recordings:`")
        return node

    def mapping(
        self, node: yaml.Node, what: str, known: Sequence[str] | None
    ) -> list[tuple[str, yaml.Node, yaml.Node]]:
        """``(key, key node, value node)`` of a mapping whose keys are given once (and are
        ``known``, when given)."""
        import yaml

        if not isinstance(node, yaml.MappingNode):
            raise self.fail(f"{what} is a mapping (`key: value` lines)", node)
        seen: dict[str, int] = {}
        out: list[tuple[str, yaml.Node, yaml.Node]] = []
        for k, v in node.value:
            if not isinstance(k, yaml.ScalarNode) or not k.value.strip():
                raise self.fail(f"{what}: a key that is not a name", k)
            line = k.start_mark.line + 1
            if k.value in seen:
                raise self.fail(
                    f"{what}: `{k.value}:` given twice (lines {seen[k.value]} and {line}; the second would replace "
                    "the first)",
                    k,
                )
            if known is not None and k.value not in known:
                keys = ", ".join(f"`{x}:`" for x in known)
                raise self.fail(f"{what}: unknown key `{k.value}:` (the keys are {keys})", k)
            seen[k.value] = line
            out.append((k.value, k, v))
        return out

    def strings(self, node: yaml.Node, what: str, words: bool = False) -> list[tuple[str, yaml.Node]]:
        """The items of a list of scalars (``words``: a scalar too, its words split as a shell does)."""
        import yaml

        if words and isinstance(node, yaml.ScalarNode):
            if node.tag == "tag:yaml.org,2002:null":
                return []
            try:
                return [(w, node) for w in shlex.split(node.value)]
            except ValueError as e:
                raise self.fail(f"{what}: {e}", node) from None
        if not isinstance(node, yaml.SequenceNode) or not all(isinstance(n, yaml.ScalarNode) for n in node.value):
            raise self.fail(f"{what} is a list", node)
        return [(n.value, n) for n in node.value]


def _kind(m: _Manifest, robot: str, node: yaml.Node) -> str:
    """The kind a robot's entry names (``kind:``)."""
    from umbmark.kinds import KINDS, kind_named

    words = m.strings(node, f"robot {robot!r}: `kind:`", words=True)
    if len(words) != 1:
        raise m.fail(f"robot {robot!r}: `kind:` is one of {', '.join(KINDS)}", node)
    try:
        return kind_named(words[0][0]).name
    except InputError as e:
        raise m.fail(f"robot {robot!r}: `kind:` {e}", node) from None


def read_manifest(path: str | Path, file_hash: Callable[[str | Path], str] | None = None) -> list[FleetJob]:
    """The jobs of a manifest: YAML ``{robots: {NAME: {recordings: [paths], kind: KIND, args: [options]}}}``
    (paths relative to the manifest's folder; ``kind`` the robot's kind, :data:`umbmark.kinds.KINDS`,
    default the differential drive; ``args`` a list, or one line of options).

    Raises
    ------
    InputError
        Naming the line: a file that is not such a manifest, a key given twice (one robot
        named twice), an unknown key (``arg:`` for ``args:``), a robot without recordings, a
        recording missing or listed twice.
    """
    from umbmark.history import check_robot, file_sha256

    h = file_hash or file_sha256
    path = Path(path)
    m = _Manifest(path)
    top = m.mapping(m.root(), "a manifest", MANIFEST_KEYS)
    robots = dict((k, v) for k, _, v in top).get("robots")
    if robots is None:
        raise m.fail("a manifest holds `robots:` mapping each robot's name to its `recordings:`")
    entries = m.mapping(robots, "`robots:`", None)
    if not entries:
        raise m.fail("`robots:` names no robot (each robot's name, then its `recordings:`)", robots)
    listed: dict[Path, tuple[str, int]] = {}
    jobs = []
    for name, key, spec in entries:
        robot = check_robot(name)
        entry = {k: v for k, _, v in m.mapping(spec, f"robot {robot!r}", ROBOT_KEYS)}
        if "recordings" not in entry:
            raise m.fail(f"robot {robot!r} needs `recordings:`, a list of paths", key)
        recs = m.strings(entry["recordings"], f"robot {robot!r}: `recordings:`")
        if not recs:
            raise m.fail(f"robot {robot!r} needs `recordings:`, a list of paths", entry["recordings"])
        given = m.strings(entry["args"], f"robot {robot!r}: `args:`", words=True) if "args" in entry else []
        args = tuple(a for a, _ in given)
        kind = _kind(m, robot, entry["kind"]) if "kind" in entry else None
        origin = f"{path}:{key.start_mark.line + 1}"
        for r, node in recs:
            p = (path.parent / r) if not Path(r).is_absolute() else Path(r)
            if not p.exists():
                raise m.fail(f"robot {robot!r}: recording {r} does not exist", node)
            if p.resolve() in listed:
                was, line = listed[p.resolve()]
                raise m.fail(f"robot {robot!r}: recording {r} is listed already (line {line}, robot {was!r})", node)
            listed[p.resolve()] = (robot, node.start_mark.line + 1)
            jobs.append(FleetJob(robot, str(p), h(p), args, _modified(p), origin, kind=kind))
    return jobs
