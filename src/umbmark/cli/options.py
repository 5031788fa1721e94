"""Flag values into the library's configuration types (SI units): the wheel data of a bag
(:class:`umbmark.io.wheels.WheelSource`), the options of a log (:class:`umbmark.io.load.LogOptions`)
and the nominal geometry given in millimetres or in ROS's metres.

Only the command line knows flags; the library takes these types.
"""

from __future__ import annotations

import math

from umbmark._check import positive_or_none
from umbmark.errors import InputError

__all__ = ["wheel_source", "read_options", "length_m", "given_nominal_m", "nominal_m", "parse_joints"]


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


def wheel_source(kw: dict):
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


def length_m(kw: dict, mm_key: str, m_key: str, m_factor: float = 1.0, both: str = "agree") -> float | None:
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


def given_nominal_m(kw: dict) -> tuple[float | None, float | None]:
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


def nominal_m(kw: dict) -> tuple[float, float]:
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


def read_options(kw: dict):
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


def kinematic_nominal(kind: str, kw: dict):
    """The nominal geometry of a tricycle or mecanum robot from ``--wheel-diameter-mm`` (or
    ``--wheel-radius-m``) and ``--wheelbase-mm`` (a tricycle) or ``--lx-plus-ly-mm`` (mecanum).

    Raises
    ------
    InputError
        A missing or non-positive size, or one that belongs to another kind.
    """
    from umbmark.model.kinematics import Mecanum, Tricycle

    d = length_m(kw, "wheel_diameter_mm", "wheel_radius_m", 2.0, both="refuse")
    if d is None:
        raise InputError("give the nominal wheel size: --wheel-diameter-mm D or --wheel-radius-m R (one of them)")
    if kw.get("wheel_separation_m") is not None:
        raise InputError(f"--wheel-separation-m is a differential drive's; a {kind} has none")
    if kind == "tricycle":
        if kw.get("lx_plus_ly_mm") is not None:
            raise InputError("--lx-plus-ly-mm is a mecanum robot's; a tricycle has --wheelbase-mm")
        positive_or_none("--wheelbase-mm", kw.get("wheelbase_mm"))
        if kw.get("wheelbase_mm") is None:
            raise InputError(
                "give the nominal wheelbase of the tricycle: --wheelbase-mm L (rear axle to steered wheel)"
            )
        return Tricycle(d, kw["wheelbase_mm"] * 1e-3)
    if kw.get("wheelbase_mm") is not None:
        raise InputError("--wheelbase-mm is a tricycle's or differential drive's; a mecanum robot has --lx-plus-ly-mm")
    positive_or_none("--lx-plus-ly-mm", kw.get("lx_plus_ly_mm"))
    if kw.get("lx_plus_ly_mm") is None:
        raise InputError(
            "give the nominal --lx-plus-ly-mm S (half the wheelbase plus half the track) of the mecanum robot"
        )
    return Mecanum.uniform(d, kw["lx_plus_ly_mm"] * 1e-3)


def kinematic_joints(kind: str, kw: dict) -> tuple[str, ...]:
    """The joint names of a tricycle (``--drive-joint``, ``--steer-joint``) or a mecanum robot
    (``--joints FL,FR,RL,RR``), in the kind's roles' order.

    Raises
    ------
    InputError
        Missing names, or flags of another kind.
    """
    if kw.get("ticks_topic") or kw.get("odom_topic"):
        raise InputError(f"a {kind} is read from its joint states (JointState), not --ticks-topic or --odom-topic")
    if kind == "tricycle":
        if kw.get("joints"):
            raise InputError("a tricycle's joints are --drive-joint NAME and --steer-joint NAME, not --joints")
        if not kw.get("drive_joint") or not kw.get("steer_joint"):
            raise InputError("a tricycle needs --drive-joint NAME (the traction wheel) and --steer-joint NAME")
        return (str(kw["drive_joint"]), str(kw["steer_joint"]))
    if kw.get("drive_joint") or kw.get("steer_joint"):
        raise InputError("--drive-joint and --steer-joint are a tricycle's; a mecanum robot has --joints FL,FR,RL,RR")
    names = [p.strip() for p in str(kw.get("joints") or "").split(",")]
    if len(names) != 4 or not all(names):
        raise InputError(
            "a mecanum robot needs --joints FL,FR,RL,RR (front left, front right, rear left, rear right), "
            f"got {kw.get('joints')!r}"
        )
    return tuple(names)
