"""The options of the commands with many of them as typed, nested configurations: ``selfcal``
(:class:`SelfcalConfig`) and ``replay`` (:class:`ReplayConfig`), each a frozen dataclass of
groups (the wheel data, the scans, the keyframes, the fit, the outputs, the history ...), each
group's fields the command's options by their parameter names, in the units the flags give them.

One place for every default: the click options take theirs from these classes (a flag's default
is its field's, ``tests/test_command_config.py`` ties each), the values shared with the library
come from :mod:`umbmark.model.defaults` (the library's settings take theirs from there too), the
next command ``selfcal`` prints names the options that differ from them, and ``--config`` /
``--write-config`` (:mod:`umbmark.cli.config`) read and write the options as YAML, a section per
command with the flags' names as keys::

    selfcal:
      odom-topic: /odom
      keyframe-mm: 300

A command makes its configuration from its parsed options (:meth:`Section.from_params`); its
values are as given, checked by the flags' checks on the way into the library's settings. Light:
building the command line imports this module, and no numerical module with it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import MISSING, Field, dataclass, field, fields, is_dataclass
from typing import Any, ClassVar, TypeVar

from umbmark.kinds import DEFAULT_KIND, KINDS, Kind
from umbmark.model.defaults import (
    HEADING_WEIGHT_M,
    JOINT_TOPIC,
    KEYFRAME_DISTANCE_M,
    KEYFRAME_MAX_INTERVAL_S,
    KEYFRAME_MIN_INTERVAL_S,
    KEYFRAME_TURN_DEG,
    LOG_FORMATS,
    LSQ_MODES,
    LSQ_SCALES,
    MAX_WHEEL_GAP_S,
    MIN_INTERVALS,
    POINTS_PER_RUN,
    SCAN_DELAY,
    SCAN_TOPIC,
    STOP_S,
    TICK_MODES,
)

__all__ = [
    "Section",
    "KindConfig",
    "NominalConfig",
    "WheelDataConfig",
    "ScansConfig",
    "KeyframesConfig",
    "SelfcalFitConfig",
    "SelfcalOutputs",
    "HistoryConfig",
    "SelfcalConfig",
    "LogNominalConfig",
    "TruthConfig",
    "RunsConfig",
    "LogConfig",
    "ReferencesConfig",
    "LsqConfig",
    "EvaluationConfig",
    "StreamConfig",
    "ReplayOutputs",
    "ReplayConfig",
    "COMMAND_CONFIGS",
    "kind_options",
    "SELFCAL",
    "REPLAY",
    "LOG",
    "HISTORY",
    "KIND",
]

S = TypeVar("S", bound="Section")

_EACH = "each"  # a field's metadata: the options a mapping field holds, with their defaults


def kind_options() -> dict[str, tuple[Kind, ...]]:
    """The options of the kinds that the default kind (the differential drive) has not: option ->
    the kinds that have it, in the registry's order (``--drive-joint``, ``--lx-plus-ly-mm``, ...)."""
    own = set(KINDS[DEFAULT_KIND].option_names())
    out: dict[str, list[Kind]] = {}
    for k in KINDS.values():
        for name in k.option_names():
            if name not in own:
                out.setdefault(name, []).append(k)
    return {name: tuple(ks) for name, ks in out.items()}


def _kind_option_defaults() -> dict[str, Any]:
    """Each kind's own option and its default: unset (a fit flag: off)."""
    fits = {f.option for k in KINDS.values() for f in k.fits}
    return {name: (False if name in fits else None) for name in kind_options()}


def _group(f: Field[Any]) -> type[Section] | None:
    """The group class of a field that holds a group of options, else None."""
    make = f.default_factory
    if make is not MISSING and isinstance(make, type) and is_dataclass(make) and issubclass(make, Section):
        return make
    return None


def _each(f: Field[Any]) -> Callable[[], dict[str, Any]] | None:
    each: Callable[[], dict[str, Any]] | None = f.metadata.get(_EACH)
    return each


class Section:
    """A group of a command's options (subclasses are frozen dataclasses): each field is an option
    by its parameter name (``keyframe_mm`` for ``--keyframe-mm``) with its default, a group of
    options (a field whose default is a :class:`Section`), or a mapping of options named by a
    registry (the kinds' own options)."""

    @classmethod
    def _leaves(cls, path: tuple[str, ...] = ()) -> Iterator[tuple[str, tuple[str, ...], Any]]:
        """``(parameter, path of attributes, default)`` of every option, depth first."""
        assert is_dataclass(cls)
        for f in fields(cls):
            group, each = _group(f), _each(f)
            if group is not None:
                yield from group._leaves((*path, f.name))
            elif each is not None:
                for name, default in each().items():
                    yield name, (*path, f.name, name), default
            else:
                default = f.default if f.default is not MISSING else f.default_factory()
                yield f.name, (*path, f.name), default

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """Every option's default, by parameter name."""
        return {name: default for name, _, default in cls._leaves()}

    @classmethod
    def default(cls, name: str) -> Any:
        """One option's default (what its flag shows).

        Raises
        ------
        KeyError
            No option ``name`` in this configuration.
        """
        return cls.defaults()[name]

    @classmethod
    def from_params(cls: type[S], params: Mapping[str, Any]) -> S:
        """The configuration of parsed options (a command's keyword arguments), the defaults where
        an option is not among them; ``params`` that are not options of it are left aside (the
        command's arguments)."""
        assert is_dataclass(cls)
        values: dict[str, Any] = {}
        for f in fields(cls):
            group, each = _group(f), _each(f)
            if group is not None:
                values[f.name] = group.from_params(params)
            elif each is not None:
                values[f.name] = {name: params.get(name, default) for name, default in each().items()}
            elif f.name in params:
                values[f.name] = params[f.name]
        return cls(**values)

    def params(self) -> dict[str, Any]:
        """Every option's value, by parameter name (flat, as the command takes them)."""
        out: dict[str, Any] = {}
        for name, path, _ in self._leaves():
            v: Any = self
            for attr in path:
                v = v[attr] if isinstance(v, Mapping) else getattr(v, attr)
            out[name] = v
        return out

    def changed(self) -> dict[str, Any]:
        """The options whose values differ from their defaults, by parameter name."""
        defaults = self.defaults()
        return {k: v for k, v in self.params().items() if v != defaults[k]}


# ---------------------------------------------------------------- groups shared by the commands
@dataclass(frozen=True)
class KindConfig(Section):
    """The kind of robot (``--kinematics``, :data:`umbmark.kinds.KINDS`) and each kind's own options
    (joints, sizes, fit flags) by their parameter names."""

    kinematics: str = DEFAULT_KIND
    options: Mapping[str, Any] = field(default_factory=_kind_option_defaults, metadata={_EACH: _kind_option_defaults})


@dataclass(frozen=True)
class NominalConfig(Section):
    """The nominal geometry: in millimetres, or in ROS's metres (one form of each)."""

    wheel_diameter_mm: float | None = None
    wheelbase_mm: float | None = None
    wheel_radius_m: float | None = None
    wheel_separation_m: float | None = None


@dataclass(frozen=True)
class WheelDataConfig(Section):
    """Where a bag's wheel data are (:class:`umbmark.io.wheels.WheelSource`): joint states, encoder
    counts or an odometry."""

    joints: str | None = None
    joint_topic: str = JOINT_TOPIC
    ticks_topic: str | None = None
    left_field: str | None = None
    right_field: str | None = None
    pulses_per_wheel_rev: float | None = None
    ticks: str = TICK_MODES[0]
    odom_topic: str | None = None


@dataclass(frozen=True)
class HistoryConfig(Section):
    """The calibration history: the robot, whether to record, the database, the record's date."""

    robot: str | None = None
    record: bool = False
    db: str | None = None
    recorded_at: str | None = None


# ---------------------------------------------------------------- umbmark selfcal
@dataclass(frozen=True)
class ScansConfig(Section):
    """The lidar's scans in a bag: their topic and frame, the lidar's pose the matching starts
    from, the robot's frame, their delay against the wheel data, the matcher's wide search."""

    scan_topic: str = SCAN_TOPIC
    sensor_pose: str | None = None
    base_frame: str | None = None
    scan_frame: str | None = None
    scan_delay: str = SCAN_DELAY
    coarse: bool = False


@dataclass(frozen=True)
class KeyframesConfig(Section):
    """When a scan becomes the next keyframe (:class:`umbmark.realrobot.selfcal.KeyframeRule`), and
    the longest gap of the wheel data a scan may fall in."""

    keyframe_mm: float = KEYFRAME_DISTANCE_M * 1e3
    keyframe_deg: float = KEYFRAME_TURN_DEG
    keyframe_s: float = KEYFRAME_MAX_INTERVAL_S
    keyframe_min_s: float = KEYFRAME_MIN_INTERVAL_S
    max_wheel_gap_s: float = MAX_WHEEL_GAP_S


@dataclass(frozen=True)
class SelfcalFitConfig(Section):
    """The fit: the fewest intervals, the outliers, the wheel data's jitter, the checks let through."""

    min_intervals: int = MIN_INTERVALS
    keep_outliers: bool = False
    wheel_jitter: bool = True
    skip_check: tuple[str, ...] = ()


@dataclass(frozen=True)
class SelfcalOutputs(Section):
    """What ``selfcal`` writes and prints besides its table."""

    save: str | None = None
    intervals_out: str | None = None
    window: str | None = None
    as_json: bool = False


@dataclass(frozen=True)
class SelfcalConfig(Section):
    """The options of ``umbmark selfcal`` (the recordings stay arguments)."""

    command: ClassVar[str] = "selfcal"

    kind: KindConfig = field(default_factory=KindConfig)
    nominal: NominalConfig = field(default_factory=NominalConfig)
    wheels: WheelDataConfig = field(default_factory=WheelDataConfig)
    scans: ScansConfig = field(default_factory=ScansConfig)
    keyframes: KeyframesConfig = field(default_factory=KeyframesConfig)
    fit: SelfcalFitConfig = field(default_factory=SelfcalFitConfig)
    outputs: SelfcalOutputs = field(default_factory=SelfcalOutputs)
    history: HistoryConfig = field(default_factory=HistoryConfig)


# ---------------------------------------------------------------- umbmark replay (and convert's logs)
@dataclass(frozen=True)
class LogNominalConfig(NominalConfig):
    """A log's nominal geometry where its format lacks it, each wheel's diameter apart if need be."""

    left_diameter_mm: float | None = None
    right_diameter_mm: float | None = None


@dataclass(frozen=True)
class TruthConfig(Section):
    """A bag's ground truth (a pose, an odometry or ``/tf``) and how late it is against the wheels."""

    gt_topic: str | None = None
    gt_frame: str | None = None
    gt_parent: str | None = None
    time_offset: str | None = None


@dataclass(frozen=True)
class RunsConfig(Section):
    """How a log becomes runs: squares of a side, cut at time ranges or where the wheels stand still."""

    side_mm: float | None = None
    ranges: str | None = None
    split_stops: bool = False
    stop_s: float = STOP_S


@dataclass(frozen=True)
class LogConfig(Section):
    """How to read a log (``replay``, ``convert``): its format, geometry, wheel data, ground truth and runs."""

    log_format: str = LOG_FORMATS[0]
    nominal: LogNominalConfig = field(default_factory=LogNominalConfig)
    wheels: WheelDataConfig = field(default_factory=WheelDataConfig)
    truth: TruthConfig = field(default_factory=TruthConfig)
    runs: RunsConfig = field(default_factory=RunsConfig)
    skip_check: tuple[str, ...] = ()


@dataclass(frozen=True)
class ReferencesConfig(Section):
    """The robot's own sensors as references: its lidar at rest (and its pose), its gyro."""

    gt_scan_topic: str | None = None
    sensor_pose: str | None = None
    imu_topic: str | None = None
    full_turns: bool = False


@dataclass(frozen=True)
class LsqConfig(Section):
    """The least squares along the path (``--method lsq``, :func:`umbmark.correct.lsq.fit_lsq`)."""

    pool: bool = False
    lsq_mode: str = LSQ_MODES[0]
    scale: str = LSQ_SCALES[0]
    heading_weight_m: float = HEADING_WEIGHT_M
    points_per_run: int = POINTS_PER_RUN
    fit_marker_offset: bool | None = None


@dataclass(frozen=True)
class EvaluationConfig(Section):
    """What else is measured: the held-out figures, the odometry's noise, windows of a recording."""

    no_heldout: bool = False
    noise: bool = False
    window: str | None = None


@dataclass(frozen=True)
class StreamConfig(Section):
    """One long CSV log replayed in bounded memory."""

    stream: bool = False
    decimate: int | None = None
    poses_out: str | None = None


@dataclass(frozen=True)
class ReplayOutputs(Section):
    """What ``replay`` writes and prints besides its tables."""

    save: str | None = None
    as_json: bool = False


@dataclass(frozen=True)
class ReplayConfig(Section):
    """The options of ``umbmark replay`` (the data sets stay arguments)."""

    command: ClassVar[str] = "replay"

    method: str = "bf"
    kind: KindConfig = field(default_factory=KindConfig)
    log: LogConfig = field(default_factory=LogConfig)
    references: ReferencesConfig = field(default_factory=ReferencesConfig)
    lsq: LsqConfig = field(default_factory=LsqConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    stream: StreamConfig = field(default_factory=StreamConfig)
    outputs: ReplayOutputs = field(default_factory=ReplayOutputs)
    history: HistoryConfig = field(default_factory=HistoryConfig)


COMMAND_CONFIGS: dict[str, type[Section]] = {"selfcal": SelfcalConfig, "replay": ReplayConfig}
"""The typed configuration of each command that has one, by the command's name."""

SELFCAL, REPLAY, LOG, HISTORY, KIND = SelfcalConfig(), ReplayConfig(), LogConfig(), HistoryConfig(), KindConfig()
"""The defaults, as the option declarations read them."""
