"""Flag values into the library's configuration types (SI units): the wheel data of a bag
(:class:`umbmark.io.wheels.WheelSource`), the options of a log (:class:`umbmark.io.load.LogOptions`)
and the nominal geometry given in millimetres or in ROS's metres.

Only the command line knows flags; the library takes these types.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from umbmark._check import positive_or_none
from umbmark.errors import InputError

if TYPE_CHECKING:
    from umbmark.io.load import LogOptions
    from umbmark.io.wheels import WheelSource
    from umbmark.model.kinematics import Kinematics

__all__ = ["flag", "wheel_source", "read_options", "length_m", "given_nominal_m", "nominal_m", "parse_joints"]


def flag(option: str) -> str:
    """The command line's flag of a library's option name (``drive_joint`` -> ``--drive-joint``)."""
    return "--" + option.replace("_", "-")


def parse_joints(text: str) -> tuple[str, str]:
    """``"left_wheel,right_wheel"`` -> ``("left_wheel", "right_wheel")``.

    Raises
    ------
    InputError
        Not two non-empty names.
    """
    parts = [j.strip() for j in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise InputError(f"--joints needs two names LEFT,RIGHT, got {text!r}")
    return parts[0], parts[1]


def wheel_source(kw: Mapping[str, Any]) -> WheelSource:
    """The :class:`~umbmark.io.wheels.WheelSource` of the bag flags (``--joints``, ``--joint-topic``,
    ``--ticks-topic``, ``--left-field``, ``--right-field``, ``--ticks``,
    ``--pulses-per-wheel-rev``, ``--odom-topic``), the readers' defaults where not given."""
    from umbmark.io.wheels import WheelSource

    joints = kw.get("joints")
    return WheelSource(
        joints=parse_joints(joints) if isinstance(joints, str) else joints,
        joint_topic=kw.get("joint_topic") or "/joint_states",
        ticks_topic=kw.get("ticks_topic"),
        left_field=kw.get("left_field"),
        right_field=kw.get("right_field"),
        ticks=kw.get("ticks") or "cumulative",
        pulses_per_wheel_rev=kw.get("pulses_per_wheel_rev"),
        odom_topic=kw.get("odom_topic"),
    )


def length_m(
    kw: Mapping[str, Any], mm_key: str, m_key: str, m_factor: float = 1.0, both: str = "agree"
) -> float | None:
    """A length given in millimetres (``mm_key``) or in ROS's metres (``m_key``, times
    ``m_factor``: 2 for a radius given for a diameter) [m]; None when neither is given.

    Parameters
    ----------
    both : str
        Both given: ``agree`` (they must) or ``refuse``.

    Raises
    ------
    InputError
        A value that is not a positive number; both forms given and refused, or disagreeing.
    """
    mm, m = kw.get(mm_key), kw.get(m_key)
    flag_mm, flag_m = "--" + mm_key.replace("_", "-"), "--" + m_key.replace("_", "-")
    if mm is not None and m is not None and both == "refuse":
        raise InputError(f"give {flag_mm} or {flag_m}, not both (one of them)")
    positive_or_none(flag_mm, mm)
    positive_or_none(flag_m, m)
    if m is None:
        return None if mm is None else mm * 1e-3
    if mm is not None and not math.isclose(mm * 1e-3, m * m_factor, rel_tol=1e-6):
        raise InputError(f"{flag_mm} {mm:g} and {flag_m} {m:g} disagree ({m * m_factor * 1e3:g} mm): give one of them")
    return m * m_factor


def given_nominal_m(kw: Mapping[str, Any]) -> tuple[float | None, float | None]:
    """The nominal wheel diameter and wheelbase [m] of ``--wheel-diameter-mm`` or ``--wheel-radius-m``
    and ``--wheelbase-mm`` or ``--wheel-separation-m`` (one form of each), None where not given.

    Raises
    ------
    InputError
        Both forms of one, a value that is not a positive number.
    """
    d = length_m(kw, "wheel_diameter_mm", "wheel_radius_m", 2.0, both="refuse")
    b = length_m(kw, "wheelbase_mm", "wheel_separation_m", both="refuse")
    return d, b


def nominal_m(kw: Mapping[str, Any]) -> tuple[float, float]:
    """As :func:`given_nominal_m`, both needed.

    Raises
    ------
    InputError
        As :func:`given_nominal_m`, and one of them missing.
    """
    d, b = given_nominal_m(kw)
    if d is None:
        raise InputError("give the nominal wheel size: --wheel-diameter-mm D or --wheel-radius-m R (one of them)")
    if b is None:
        raise InputError("give the nominal wheelbase: --wheelbase-mm B or --wheel-separation-m S (one of them)")
    return d, b


def read_options(kw: Mapping[str, Any]) -> LogOptions:
    """The :class:`~umbmark.io.load.LogOptions` of the log flags of ``replay`` and ``convert``.

    Raises
    ------
    InputError
        A number that is not positive, the mm and metre forms of one length disagree, a bad
        ``--ranges`` or ``--joints``.
    """
    from umbmark.io.load import LogOptions, TruthSource, parse_ranges

    for k in ("side_mm", "left_diameter_mm", "right_diameter_mm", "pulses_per_wheel_rev", "stop_s"):
        positive_or_none("--" + k.replace("_", "-"), kw.get(k))
    d = length_m(kw, "wheel_diameter_mm", "wheel_radius_m", 2.0)
    mm = lambda k: None if kw.get(k) is None else kw[k] * 1e-3  # noqa: E731
    ranges = kw.get("ranges")
    return LogOptions(
        diameter_left_m=mm("left_diameter_mm") or d,
        diameter_right_m=mm("right_diameter_mm") or d,
        wheelbase_m=length_m(kw, "wheelbase_mm", "wheel_separation_m"),
        pulses_per_wheel_rev=kw.get("pulses_per_wheel_rev"),
        ticks=kw.get("ticks") or "cumulative",
        wheels=wheel_source(kw),
        truth=TruthSource(kw.get("gt_topic"), kw.get("gt_frame"), kw.get("gt_parent")),
        side_m=mm("side_mm"),
        ranges_s=None if ranges is None else tuple(parse_ranges(ranges) if isinstance(ranges, str) else ranges),
        split_stops=bool(kw.get("split_stops")),
        stop_s=kw.get("stop_s") or 1.0,
        time_offset=kw.get("time_offset"),
    )


def kinematic_nominal(kind: str, kw: Mapping[str, Any]) -> Kinematics:
    """The nominal geometry of a robot of a kind of its own from its sizes' flags
    (:attr:`umbmark.kinds.Kind.sizes`: ``--wheel-diameter-mm`` or ``--wheel-radius-m``, a
    tricycle's ``--wheelbase-mm``, a mecanum robot's ``--lx-plus-ly-mm``).

    Raises
    ------
    InputError
        A size of another kind, a missing or non-positive size.
    """
    from umbmark.kinds import KINDS, kind_named, kinds_with

    k = kind_named(kind)
    own = {s.option for s in k.sizes} | {s.alternative.option for s in k.sizes if s.alternative is not None}
    common = set.intersection(*({s.option for s in x.sizes} for x in KINDS.values()))
    mine = " and ".join(flag(s.option) for s in k.sizes if s.option not in common) or "none"
    for x in KINDS.values():
        for s in x.sizes:
            for name in (s.option, *(() if s.alternative is None else (s.alternative.option,))):
                if name not in own and kw.get(name) is not None:
                    owners = " or ".join(f"{o.noun}'s" for o in kinds_with(name))
                    raise InputError(f"{flag(name)} is a {owners}; a {k.noun} has {mine}")
    sizes: dict[str, float] = {}
    for s in k.sizes:
        alt = s.alternative
        if alt is not None:
            v = length_m(kw, s.option, alt.option, alt.factor, both="refuse")
        else:
            positive_or_none(flag(s.option), kw.get(s.option))
            v = None if kw.get(s.option) is None else kw[s.option] * 1e-3
        if v is None and s.fallback is not None:
            continue  # the kind takes the other size's (umbmark.kinds.Kind.nominal)
        if v is None:
            other = "" if alt is None else f" or {flag(alt.option)} {alt.metavar} (one of them)"
            what = f" ({s.describe})" if s.describe else ""
            raise InputError(f"give the nominal {s.label} of the {k.noun}: {flag(s.option)} {s.metavar}{other}{what}")
        sizes[s.option] = v
    return k.nominal(sizes)


def kinematic_joints(kind: str, kw: Mapping[str, Any]) -> tuple[str, ...]:
    """The joint names of a robot of a kind of its own from its joints' flags
    (:attr:`umbmark.kinds.Kind.joints`: a tricycle's ``--drive-joint`` and ``--steer-joint``, a
    mecanum robot's ``--joints FL,FR,RL,RR``), in the kind's roles' order.

    With ``--odom-topic`` (a kind that reads the robot's own odometry,
    :attr:`umbmark.kinds.Kind.reads_odometry`) no joints: empty.

    Raises
    ------
    InputError
        Missing names, flags of another kind, joints and an odometry both given, an odometry or
        encoder counts for a kind that reads neither.
    """
    from umbmark.kinds import KINDS, kind_named, kinds_with

    k = kind_named(kind)
    if kw.get("ticks_topic"):
        raise InputError(f"a {kind} is read from its joint states (JointState), not --ticks-topic")
    if kw.get("odom_topic"):
        if not k.reads_odometry:
            raise InputError(k.odometry_refusal())
        given = [flag(j.option) for j in k.joints if kw.get(j.option)]
        if given:
            raise InputError(f"give the joints ({' and '.join(given)}) or --odom-topic, not both")
        return ()
    own = [j.option for j in k.joints]
    wanted = " and ".join(
        f"{flag(j.option)} {j.metavar}" + (f" ({j.describe})" if j.describe else "") for j in k.joints
    )
    foreign = dict.fromkeys(
        j.option for x in KINDS.values() for j in x.joints if j.option not in own and kw.get(j.option)
    )
    if foreign:
        first = next(iter(foreign))
        owners = " or ".join(f"{o.noun}'s" for o in kinds_with(first))
        listed = " and ".join(f"{flag(j.option)} {j.metavar}" for j in k.joints)
        raise InputError(f"a {k.noun}'s joints are {listed}, not {' or '.join(map(flag, foreign))} (a {owners})")
    names: list[str] = []
    for j in k.joints:
        v = kw.get(j.option)
        parts = [p.strip() for p in str(v or "").split(",")] if len(j.roles) > 1 else [str(v or "")]
        if len(parts) != len(j.roles) or not all(parts):
            raise InputError(f"a {k.noun} needs {wanted}" + (f", got {v!r}" if len(j.roles) > 1 else ""))
        names += parts
    return tuple(names)
