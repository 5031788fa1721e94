"""Where a recording's wheel data are (:class:`WheelSource`) and the wheel data read from it
(:class:`WheelData`): what every bag reader takes and gives for the wheels.

A robot's wheels are recorded one of three ways:

* ``sensor_msgs/JointState`` on ``joint_topic``: the positions [rad] of the wheel joints named
  ``joints=(left, right)``;
* encoder counts: the fields ``left_field`` / ``right_field`` of the messages on
  ``ticks_topic`` (attribute paths such as ``left_ticks`` or ``data[0]``), a running counter
  (``ticks="cumulative"``) or counts per message (``"incremental"``), ``pulses_per_wheel_rev``
  pulses per wheel revolution;
* ``nav_msgs/Odometry`` on ``odom_topic``: the odometry the robot computed, turned back into
  wheel travel through the nominal geometry (:meth:`WheelData.angles`, with
  :func:`umbmark.model.dataset.wheel_travel_from_poses`, the one inversion of the odometry).

:func:`umbmark.io.rosbag.read_bag`, :func:`~umbmark.io.rosbag.read_selfcal_bag`,
:func:`~umbmark.io.rosbag.read_gyro_bag` and :func:`umbmark.realrobot.scan_truth.attach_scan_truth`
take a :class:`WheelSource`; the bag module decodes its messages and checks them once
(:func:`umbmark.model.timing.check_wheel_stream`) into a :class:`WheelData`.

Imports numpy and :mod:`umbmark.model` only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from umbmark.errors import InputError
from umbmark.model.dataset import wheel_angles_from_poses
from umbmark.model.defaults import JOINT_TOPIC, TICK_MODES
from umbmark.model.geometry import WheelGeometry
from umbmark.model.wheel_stream import StreamReport

__all__ = ["WheelSource", "WheelData", "TICK_MODES", "WHEEL_KINDS", "MAX_PULSES_PER_WHEEL_REV", "ONE_WHEEL_SOURCE"]

FloatArray = NDArray[np.float64]

WHEEL_KINDS = ("joints", "ticks", "odom")
"""The kinds of wheel data: joint states, encoder counts, an odometry."""

MAX_PULSES_PER_WHEEL_REV = 1e9
"""The largest encoder resolution any robot's wheel has (pulses per wheel revolution)."""

_WHAT = {"joints": "joint states", "ticks": "encoder counts", "odom": "odometry poses"}
ONE_WHEEL_SOURCE = (
    "the wheel joints (`joints`) of a JointState topic, a ticks topic with its fields (`ticks_topic`) or an "
    "odometry topic (`odom_topic`)"
)


@dataclass(frozen=True)
class WheelSource:
    """Where a recording's wheel data are: one of joint states, encoder counts or an odometry.

    Parameters
    ----------
    joints : tuple of str, optional
        The wheel joints of the ``sensor_msgs/JointState`` messages on ``joint_topic``: a
        differential drive's ``(left, right)``; any other kind of robot's joints in its
        :attr:`~umbmark.model.kinematics.Kinematics.joint_roles` order (a tricycle's
        ``(drive, steer)``, a mecanum robot's ``(front_left, front_right, rear_left,
        rear_right)``); or:
    ticks_topic, left_field, right_field : str, optional
        A topic of encoder counts and the fields of the left and right count, with ``ticks``
        and ``pulses_per_wheel_rev``; or:
    odom_topic : str, optional
        A ``nav_msgs/Odometry`` topic (the odometry the robot computed, e.g.
        diff_drive_controller's ``/odom``).
    joint_topic : str
        The JointState topic.
    ticks : str
        ``cumulative`` or ``incremental`` counts (:data:`TICK_MODES`).
    pulses_per_wheel_rev : float, optional
        Encoder pulses per wheel revolution (needed with ``ticks_topic``).
    steer_joints : tuple of str
        Of ``joints``, those that hold a steering angle [rad] rather than roll.

    Notes
    -----
    :meth:`check` refuses a source that is not exactly one of the three, or incomplete; it is
    called by the readers before they open a bag.
    """

    joints: tuple[str, ...] | None = None
    joint_topic: str = JOINT_TOPIC
    ticks_topic: str | None = None
    left_field: str | None = None
    right_field: str | None = None
    ticks: str = TICK_MODES[0]
    pulses_per_wheel_rev: float | None = None
    odom_topic: str | None = None
    steer_joints: tuple[str, ...] = ()

    @classmethod
    def joint_states(cls, left: str, right: str, topic: str = JOINT_TOPIC) -> WheelSource:
        """The wheel joints ``left`` and ``right`` of the JointState messages on ``topic``."""
        return cls(joints=(left, right), joint_topic=topic)

    @classmethod
    def robot_joints(
        cls, joints: tuple[str, ...], steer_joints: tuple[str, ...] = (), topic: str = JOINT_TOPIC
    ) -> WheelSource:
        """The joints of any kind of robot (its roles' order), ``steer_joints`` among them."""
        return cls(joints=tuple(joints), joint_topic=topic, steer_joints=tuple(steer_joints))

    @property
    def rolling(self) -> tuple[bool, ...]:
        """Per joint: it rolls (a wheel), else it holds a steering angle."""
        return tuple(j not in self.steer_joints for j in (self.joints or ()))

    @property
    def two_wheels(self) -> bool:
        """The data are a differential drive's two wheels (joints, encoder counts or an odometry)."""
        return self.joints is None or (len(self.joints) == 2 and not self.steer_joints)

    @classmethod
    def encoder_counts(
        cls, topic: str, left_field: str, right_field: str, pulses_per_wheel_rev: float, ticks: str = TICK_MODES[0]
    ) -> WheelSource:
        """Encoder counts in the fields ``left_field`` and ``right_field`` of the messages on ``topic``."""
        return cls(
            ticks_topic=topic,
            left_field=left_field,
            right_field=right_field,
            pulses_per_wheel_rev=pulses_per_wheel_rev,
            ticks=ticks,
        )

    @classmethod
    def odometry(cls, topic: str) -> WheelSource:
        """The ``nav_msgs/Odometry`` on ``topic``."""
        return cls(odom_topic=topic)

    @property
    def given(self) -> int:
        """How many sources are given (1 for a usable source)."""
        return sum(v is not None for v in (self.joints, self.ticks_topic, self.odom_topic))

    @property
    def kind(self) -> str:
        """``joints``, ``ticks`` or ``odom`` (:data:`WHEEL_KINDS`); ``""`` when no source is given."""
        if self.joints is not None:
            return "joints"
        if self.ticks_topic is not None:
            return "ticks"
        return "odom" if self.odom_topic is not None else ""

    @property
    def topic(self) -> str:
        """The topic of the wheel data."""
        return {"joints": self.joint_topic, "ticks": str(self.ticks_topic), "odom": str(self.odom_topic)}.get(
            self.kind, ""
        )

    @property
    def what(self) -> str:
        """What the messages are, in words (``joint states``, ``encoder counts``, ``odometry poses``)."""
        return _WHAT.get(self.kind, "wheel data")

    @property
    def units_per_wheel_rev(self) -> float:
        """Log units per wheel revolution: ``2 pi`` for joint angles and odometry, the pulses for encoders."""
        if self.kind != "ticks":
            return 2.0 * math.pi
        assert self.pulses_per_wheel_rev is not None  # check() requires it with a ticks topic
        return float(self.pulses_per_wheel_rev)

    @property
    def cumulative(self) -> bool:
        """The values are positions (else counts per message)."""
        return self.kind != "ticks" or self.ticks == "cumulative"

    @property
    def description(self) -> str:
        """Where the wheel data come from, in words (for reports)."""
        if self.kind == "joints":
            assert self.joints is not None
            return f"JointState {', '.join(self.joints)} on {self.joint_topic}"
        if self.kind == "ticks":
            return (
                f"encoder counts {self.left_field}, {self.right_field} on {self.ticks_topic} ({self.ticks}, "
                f"{self.units_per_wheel_rev:g} per rev)"
            )
        return f"nav_msgs/Odometry on {self.odom_topic}" if self.kind == "odom" else "no wheel data"

    def check(self, source: str | None = None, two_wheels: bool = True) -> None:
        """Refuse a source that is not exactly one of the three, or incomplete.

        Parameters
        ----------
        source : str, optional
            The recording, for messages.
        two_wheels : bool
            Only a differential drive's two wheels will do (else any joints, at least one of
            them rolling).

        Raises
        ------
        InputError
            Several sources, none, a tick mode not in :data:`TICK_MODES`, a ticks topic without
            both fields or without a positive encoder resolution (at most
            :data:`MAX_PULSES_PER_WHEEL_REV`), joints that are not two names.
        """
        if self.given > 1:
            raise InputError(f"give one source of wheel data, not several: {ONE_WHEEL_SOURCE}", source)
        if self.given == 0:
            raise InputError(f"give the wheel data: {ONE_WHEEL_SOURCE}", source)
        if self.ticks not in TICK_MODES:
            raise InputError(f"ticks must be 'cumulative' or 'incremental', got {self.ticks!r}", source)
        if self.joints is not None:
            names = self.joints
            named = all(isinstance(j, str) and j for j in names)
            if two_wheels and not (self.two_wheels and named):
                raise InputError(f"`joints` needs two names LEFT,RIGHT, got {names!r}", source)
            if not named or len(set(names)) != len(names):
                raise InputError(f"`joints` must be distinct names, got {names!r}", source)
            if not set(self.steer_joints) <= set(names) or not any(self.rolling):
                raise InputError(
                    f"the steering joints {self.steer_joints!r} must be among the joints {names!r}, "
                    "beside at least one wheel",
                    source,
                )
        ppr = self.pulses_per_wheel_rev
        if self.kind == "ticks" or ppr is not None:
            if self.kind == "ticks" and (not self.left_field or not self.right_field):
                raise InputError("a ticks topic needs `left_field` and `right_field`", source)
            if ppr is None or not (
                isinstance(ppr, (int, float)) and math.isfinite(ppr) and 0 < ppr <= MAX_PULSES_PER_WHEEL_REV
            ):
                raise InputError(
                    "encoder ticks need the pulses per wheel revolution (`pulses_per_wheel_rev`), a positive "
                    f"number of at most {MAX_PULSES_PER_WHEEL_REV:g}, got {ppr!r}",
                    source,
                )


@dataclass(frozen=True, eq=False)
class WheelData:
    """A recording's wheel data, read and checked (:func:`umbmark.model.timing.check_wheel_stream`).

    Attributes
    ----------
    source : WheelSource
        Where they were read from.
    t_s : numpy.ndarray
        ``(K,)`` stamps [s], increasing.
    left, right : numpy.ndarray or None
        ``(K,)`` cumulative wheel positions in log units (radians for joint states, counts for
        encoders); None for an odometry.
    odom_pose : numpy.ndarray or None
        ``(K, 3)`` odometry poses ``(x_m, y_m, yaw_rad)`` (yaw as recorded); None otherwise.
    odom_child_frame : str or None
        The odometry's ``child_frame_id`` when it names one frame.
    warnings : tuple of str
        What the checks found and did.
    joints : numpy.ndarray or None
        ``(K, J)`` every joint's position [rad] in the order of :attr:`WheelSource.joints`
        (rolling joints cumulative, steering joints their angle); None for encoder counts and
        odometry.
    stream : StreamReport or None
        What the check of the stream found and did (rate, bursts, messages dropped and why).
    """

    source: WheelSource
    t_s: FloatArray
    left: FloatArray | None
    right: FloatArray | None
    odom_pose: FloatArray | None = None
    odom_child_frame: str | None = None
    warnings: tuple[str, ...] = ()
    joints: FloatArray | None = None
    stream: StreamReport | None = None

    @property
    def kind(self) -> str:
        """``joints``, ``ticks`` or ``odom``."""
        return self.source.kind

    def positions(self, nominal: WheelGeometry) -> tuple[FloatArray, FloatArray]:
        """The cumulative wheel positions in log units (:attr:`WheelSource.units_per_wheel_rev` a turn):
        as recorded, or from an odometry through ``nominal`` (:meth:`angles`)."""
        if self.odom_pose is None:
            assert self.left is not None and self.right is not None
            return self.left, self.right
        return self.angles(nominal)

    def angles(self, nominal: WheelGeometry) -> tuple[FloatArray, FloatArray]:
        """The cumulative wheel angles [rad] (0 where an odometry starts).

        Joint states and encoder counts as recorded (counts over the pulses per revolution);
        an odometry's pose increments turned into wheel travel through the nominal wheelbase
        (:func:`umbmark.model.dataset.wheel_angles_from_poses`, exact arcs) and into angles
        through the nominal diameters.

        Parameters
        ----------
        nominal : WheelGeometry
            The geometry the odometry was computed with (unused for joint states and encoders).

        Returns
        -------
        tuple of numpy.ndarray
            ``(left_rad, right_rad)``, each ``(K,)``.
        """
        if self.odom_pose is not None:
            return wheel_angles_from_poses(self.odom_pose, nominal)
        assert self.left is not None and self.right is not None
        k = 2.0 * math.pi / self.source.units_per_wheel_rev
        return self.left * k, self.right * k
