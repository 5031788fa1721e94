"""The field procedure of the bi-directional UMBmark test, as text (``umbmark guide``), and a ROS 2
node that drives its squares closed loop on the robot's own odometry
(``umbmark guide --ros2-script``)."""

from __future__ import annotations

import math
import re

from umbmark._check import positive_or_none
from umbmark.errors import InputError

__all__ = ["STEP_TITLES", "check_run_plan", "guide_text", "ros2_runs_script"]

STEP_TITLES = (
    "Before you start",
    "Mark three reference points on the robot",
    "Choose the start area: the corner of two perpendicular walls",
    "Program the square",
    "One run, step by step",
    "5 runs each way",
    "What to type",
    "Compute the calibration",
    "Load it and check",
)


SIDE_RANGE_M = (0.25, 50.0)
"""The sides of a square a UMBmark test is driven on (the paper's: 4 m)."""
MAX_SPEED_M_S = 3.0
"""The fastest a calibration run is driven (the paper's: 0.2 m/s)."""
MAX_TURN_RATE_DEG_S = 360.0
"""The fastest turn on the spot of a calibration run."""


def _check_positive(**values: float | None) -> None:
    """Refuse a value (given by its parameter's name) that is not a positive number; None passes."""
    for name, v in values.items():
        positive_or_none(f"`{name}`", v)


# a rest between runs longer than this (seconds) is no rest between runs
MAX_PAUSE_S = 600.0
MAX_TEST_S = 8 * 3600.0
"""The longest a whole test (every run of both directions, legs, turns and rests) is driven: a
working day on one charge (the paper's ten runs take about 20 minutes)."""


def _test_duration_s(side_m: float, runs: int, speed_m_s: float, turn_rate_deg_s: float, pause_s: float) -> float:
    one_run_s = 4 * side_m / speed_m_s + 4 * 90.0 / turn_rate_deg_s
    return 2 * runs * (one_run_s + pause_s)


def _check_duration(side_m, runs, speed_m_s, turn_rate_deg_s, pause_s) -> None:
    """Refuse a plan that drives longer than :data:`MAX_TEST_S`, naming the value that makes it
    so (a speed or turn rate in another unit, or runs no test has)."""
    total_s = _test_duration_s(side_m, runs, speed_m_s, turn_rate_deg_s, pause_s)
    if not total_s > MAX_TEST_S:
        return
    legs_s, turns_s = 4 * side_m / speed_m_s, 4 * 90.0 / turn_rate_deg_s
    hours = f"{total_s / 3600:.3g} h"
    if legs_s >= MAX_TEST_S / 10:
        why = (
            f"`speed_m_s` {speed_m_s:g}: the four {side_m:g} m legs of one run take {legs_s / 3600:.3g} h at this "
            "speed (the speed is in metres per second; the paper's is 0.2)"
        )
    elif turns_s >= MAX_TEST_S / 10:
        why = (
            f"`turn_rate_deg_s` {turn_rate_deg_s:g}: the four turns of one run take {turns_s / 3600:.3g} h at this "
            "rate (the rate is in degrees per second; 30 is usual)"
        )
    else:
        why = f"`runs` {runs}: runs per direction (the paper drives 5)"
    raise InputError(f"{why}: the test would take {hours}, more than a day's driving ({MAX_TEST_S / 3600:g} h)")


def check_run_plan(
    side_m: float,
    speed_m_s: float | None = None,
    turn_rate_deg_s: float | None = None,
    pause_s: float | None = None,
    runs: int | None = None,
) -> None:
    """Refuse a plan no calibration run is driven with, naming the likely unit slip.

    Parameters
    ----------
    side_m : float
        Side of the square [m].
    speed_m_s : float, optional
        Speed on the legs [m/s].
    turn_rate_deg_s : float, optional
        Turn rate on the spot [deg/s].
    pause_s : float, optional
        Rest between runs [s].
    runs : int, optional
        Runs per direction.

    Raises
    ------
    InputError
        A value that is not a positive number, or outside :data:`SIDE_RANGE_M`,
        :data:`MAX_SPEED_M_S`, :data:`MAX_TURN_RATE_DEG_S` or :data:`MAX_PAUSE_S`; a plan
        (with every value given) that drives longer than :data:`MAX_TEST_S`.
    """
    _check_positive(side_m=side_m, speed_m_s=speed_m_s, turn_rate_deg_s=turn_rate_deg_s, pause_s=pause_s)
    if pause_s is not None and pause_s > MAX_PAUSE_S:
        raise InputError(
            f"`pause_s` {pause_s:g}: a rest between runs of more than {MAX_PAUSE_S:g} s (the pause is in seconds)"
        )
    lo, hi = SIDE_RANGE_M
    if not lo <= side_m <= hi:
        raise InputError(
            f"a square of {side_m:g} m ({side_m * 1e3:g} mm) sides is not a UMBmark test ({lo:g} to {hi:g} m; the "
            "paper's is 4 m): "
            "millimetres and metres mixed up?"
        )
    if speed_m_s is not None and speed_m_s > MAX_SPEED_M_S:
        raise InputError(
            f"`speed_m_s` {speed_m_s:g}: faster than a calibration run is driven (at most {MAX_SPEED_M_S:g} m/s; "
            "the paper's is 0.2): the speed is in metres per second"
        )
    if turn_rate_deg_s is not None and turn_rate_deg_s > MAX_TURN_RATE_DEG_S:
        raise InputError(
            f"`turn_rate_deg_s` {turn_rate_deg_s:g}: faster than a robot turns on the spot for a calibration run "
            f"(at most {MAX_TURN_RATE_DEG_S:g} deg/s; 30 is usual): the rate is in degrees per second"
        )
    if runs is not None and speed_m_s is not None and turn_rate_deg_s is not None:
        _check_duration(side_m, runs, speed_m_s, turn_rate_deg_s, pause_s or 0.0)


def guide_text(side_mm: float = 4000.0, runs: int = 5, speed_m_s: float = 0.2) -> str:
    """The field procedure of the UMBmark test, step by step.

    Parameters
    ----------
    side_mm : float
        The side of the square.
    runs : int
        Runs per direction.
    speed_m_s : float
        The driving speed the procedure names.

    Returns
    -------
    str
        Plain text, at most 100 columns, one numbered step per :data:`STEP_TITLES` entry.

    Raises
    ------
    InputError
        A side or speed no calibration run is driven with (:func:`check_run_plan`).
    """
    _check_positive(side_mm=side_mm)
    check_run_plan(side_mm / 1000.0, speed_m_s)
    L = f"{side_mm:g}"
    Lm = f"{side_mm / 1000:g}"
    steps = [
        f"""Tyres at their usual pressure, the usual load on board, batteries charged: the calibration
   holds for the robot as it drives every day. Check the distance scale first (the square test
   cannot see it): drive {Lm} m straight, measure the distance travelled with the tape, and correct
   the nominal wheel diameter if the odometry disagrees.""",
        """Two marks on the same side of the robot, one near the front and one near the rear, as far
   apart as possible (e.g. two chassis corners), and one at the middle of the back. Measure their
   coordinates in the ROBOT frame, in millimetres: origin at the midpoint of the wheel axle, x
   forward, y to the left (points on the right side have negative y). These are --front X,Y,
   --rear X,Y and --back X,Y of `umbmark measure`. Put the same marks on the other side too
   (mirrored): the cw and ccw runs use opposite sides.""",
        f"""Find a corner of two walls at right angles with {Lm} x {Lm} m of free, flat floor next to it.
   The "back wall" is behind the robot, the "side wall" runs along the robot's side, the robot
   faces along the side wall into the room, 30 to 50 cm from both walls. The square must turn
   AWAY from the side wall: for the cw runs (right turns) the side wall is on the robot's LEFT,
   for the ccw runs (left turns) on its RIGHT: use the two corners at the two ends of one back
   wall. Mark each start with tape around the wheels so you can put the robot back on it.""",
        f"""The robot drives four {L} mm legs and turns 90 degrees on the spot at each corner, stopping
   after each leg (the paper: {speed_m_s:g} m/s). A cw run starts along +x (the first leg) and turns
   right; a ccw run starts along +x and turns left. The controller only needs to get back near
   the start: the test measures the odometry, not the controller.""",
        """  a. Put the robot on the start marks.
  b. START distances, in mm, each perpendicular to the wall, tape flat on the floor:
     front mark -> side wall, rear mark -> side wall, back mark -> back wall.
  c. Reset the odometry to x = 0, y = 0, theta = 0 (the START FRAME: x along the first leg,
     y to the left, angles counter-clockwise).
  d. Run the square. Do not touch the robot afterwards.
  e. Read the robot's odometry at the end: x_odo, y_odo (mm) and theta_odo (deg), as it
     reports them in the start frame.
  f. END distances: the same three measurements again, against the same two walls.
  umbmark measure turns these six distances into where the robot really stopped, in the start
  frame (x_abs, y_abs, theta_abs), and propagates the tape's resolution into its error.""",
        f"""{runs} runs clockwise and {runs} runs counter-clockwise (the paper: 5 each way). More runs shrink
   the error of the centres of gravity (SEM = sigma / sqrt(n)). Note anything odd (a wheel
   slipped, a bump) and repeat that run rather than editing the numbers.""",
        """One row per run in a CSV file (mm and degrees), e.g. distances.csv:

   run,direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo,theta_odo
   1,cw,409,411,350,294,278,471,45.7,44.9,-1.30
   1,ccw,409,411,350,188,150,633,43.7,-44.9,1.29

   Empty start cells reuse the previous start of the same direction. Or type the rows
   at the prompts: umbmark measure --interactive ... (it saves after every run). If you measure
   the end pose another way (a motion-capture system, a grid on the floor), write the runs file
   directly: run,direction,x_abs,y_abs,x_odo,y_odo[,theta_abs,theta_odo], in the start frame.""",
        f"""umbmark measure distances.csv --front 150,-120 --rear -150,-120 --back -200,0 --out runs.csv
   umbmark analyze runs.csv --wheelbase-mm <nominal> --side-mm {L} --robot <name> --record
   analyze prints E_max,syst, the correction factors c_left, c_right and the corrected
   wheelbase; --record stores them in the robot's history (umbmark history <name>).""",
        """Load c_left, c_right and the new wheelbase into the robot's odometry (umbmark history <name>
   --export params.json writes them) and run the test again. E_max,syst should drop roughly
   ten-fold (the paper: 317 mm -> 21 mm). If it is still above 3 x SEM, analyze the new runs
   with --c-left/--c-right/--wheelbase-mm set to what the robot now uses (a second pass).
   Re-run the test when the load or the tyres change: umbmark history <name> --plot shows drift.""",
    ]
    out = [f"UMBmark field procedure (bi-directional square test, {L} mm sides)", ""]
    for i, (title, body) in enumerate(zip(STEP_TITLES, steps), 1):
        out.append(f"{i}. {title}")
        out.append(body if body.startswith("  ") else "   " + body)
        out.append("")
    return "\n".join(out).rstrip() + "\n"


_SCRIPT = '''#!/usr/bin/env python3
"""Drive the UMBmark runs of a ROS 2 robot, closed loop on its own odometry (as the paper's robot).

@@RUNS@@ clockwise, then @@RUNS@@ counter-clockwise squares of @@SIDE_M@@ m. A leg ends when the odometry
has covered the side, a turn when the odometry has turned 90 degrees; the robot rests
@@PAUSE_S@@ s between runs (where `umbmark replay --split-stops` cuts the bag into runs).

Written by `umbmark guide --ros2-script`. Start the bag recording first, in another terminal:
    ros2 bag record -o calibration_bag /joint_states /mocap/robot/pose
then run this file with a sourced ROS 2 environment:  python3 umbmark_runs.py
Keep a hand on the emergency stop. Ctrl-C stops the robot; the robot also stops whenever the
odometry is older than STALE_S seconds.
"""

import math

SIDE_M = @@SIDE_M@@
RUNS = @@RUNS@@
SPEED_M_S = @@SPEED_M_S@@
TURN_RATE_RAD_S = @@TURN_RATE_RAD_S@@
PAUSE_S = @@PAUSE_S@@
CMD_VEL_TOPIC = @@CMD_VEL_TOPIC@@
ODOM_TOPIC = @@ODOM_TOPIC@@
STAMPED = @@STAMPED@@
RATE_HZ = 50.0
STALE_S = 0.5
APPROACH_GAIN = 2.0  # 1/s: the command shrinks in proportion to what is left of a leg or turn
MIN_FRACTION = 0.1  # the slowest approach, as a fraction of the speed or turn rate
HEADING_GAIN = 1.0  # rad/s per rad: a leg holds the heading it started with


def wrap(a):
    """An angle in (-pi, pi]."""
    return math.pi - (math.pi - a) % (2.0 * math.pi)


class SquareDriver:
    """The runs as a sequence of legs, turns and rests, driven on the odometry pose (no ROS here)."""

    def __init__(self):
        self.steps = []
        for direction, sign in (("cw", -1.0), ("ccw", 1.0)):
            for run in range(1, RUNS + 1):
                label = f"{direction} run {run} of {RUNS}"
                self.steps += [("leg", sign, label), ("turn", sign, label)] * 4
                self.steps.append(("rest", sign, label))
        self.index = 0
        self.start = None

    @property
    def label(self):
        """The run the current step belongs to (None when all are done)."""
        return self.steps[self.index][2] if self.index < len(self.steps) else None

    def command(self, t, x, y, yaw):
        """(forward m/s, turn rad/s) for the odometry pose (x, y, yaw) at time t; None when done."""
        if self.index >= len(self.steps):
            return None
        kind, sign, _ = self.steps[self.index]
        if self.start is None:
            self.start = (t, x, y, yaw)
        t0, x0, y0, yaw0 = self.start
        if kind == "leg":
            left = SIDE_M - math.hypot(x - x0, y - y0)
            if left <= 0.0:
                return self._next()
            v = min(SPEED_M_S, max(MIN_FRACTION * SPEED_M_S, APPROACH_GAIN * left))
            return v, -HEADING_GAIN * wrap(yaw - yaw0)
        if kind == "turn":
            left = math.pi / 2.0 - abs(wrap(yaw - yaw0))
            if left <= 0.0:
                return self._next()
            w = min(TURN_RATE_RAD_S, max(MIN_FRACTION * TURN_RATE_RAD_S, APPROACH_GAIN * left))
            return 0.0, sign * w
        if t - t0 >= PAUSE_S:
            return self._next()
        return 0.0, 0.0

    def _next(self):
        self.index += 1
        self.start = None
        return 0.0, 0.0


def yaw_of(q):
    """The yaw of a quaternion message."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def main():
    import rclpy
    from geometry_msgs.msg import Twist, TwistStamped
    from nav_msgs.msg import Odometry
    from rclpy.node import Node

    class Runner(Node):
        def __init__(self):
            super().__init__("umbmark_runs")
            self.driver = SquareDriver()
            self.pose = None
            self.pose_time = None
            self.finished = False
            self.said = None
            self.pub = self.create_publisher(TwistStamped if STAMPED else Twist, CMD_VEL_TOPIC, 10)
            self.create_subscription(Odometry, ODOM_TOPIC, self.on_odom, 10)
            self.create_timer(1.0 / RATE_HZ, self.tick)

        def now(self):
            return self.get_clock().now().nanoseconds * 1e-9

        def on_odom(self, msg):
            p = msg.pose.pose
            self.pose = (p.position.x, p.position.y, yaw_of(p.orientation))
            self.pose_time = self.now()

        def tick(self):
            t = self.now()
            if self.pose is None or t - self.pose_time > STALE_S:
                self.say(f"waiting for odometry on {ODOM_TOPIC}")
                self.send(0.0, 0.0)
                return
            cmd = self.driver.command(t, *self.pose)
            if cmd is None:
                self.finished = True
                cmd = (0.0, 0.0)
            else:
                self.say(self.driver.label or "done")
            self.send(*cmd)

        def say(self, text):
            if text != self.said:
                self.get_logger().info(text)
                self.said = text

        def send(self, v, w):
            msg = TwistStamped() if STAMPED else Twist()
            twist = msg.twist if STAMPED else msg
            if STAMPED:
                msg.header.stamp = self.get_clock().now().to_msg()
            twist.linear.x = float(v)
            twist.angular.z = float(w)
            self.pub.publish(msg)

    rclpy.init()
    node = Runner()
    try:
        while rclpy.ok() and not node.finished:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.send(0.0, 0.0)
        node.get_logger().info("done: stop the recording")
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
'''


def ros2_runs_script(
    side_m: float = 2.0,
    runs: int = 5,
    speed_m_s: float = 0.2,
    turn_rate_deg_s: float = 30.0,
    cmd_vel_topic: str = "/cmd_vel",
    odom_topic: str = "/odom",
    stamped: bool = False,
    pause_s: float = 8.0,
) -> str:
    """A ROS 2 Python node that drives the UMBmark runs closed loop on the robot's odometry.

    ``runs`` clockwise squares, then ``runs`` counter-clockwise ones; a leg ends when the
    odometry (``nav_msgs/Odometry`` on ``odom_topic``) has covered ``side_m``, a turn when it has
    turned 90 degrees, with ``pause_s`` seconds at rest between runs. The driving logic is a
    plain class (``SquareDriver``) of the script, free of ROS, so it can be tested on its own.

    Parameters
    ----------
    side_m : float
        Side of the square.
    runs : int
        Runs per direction.
    speed_m_s, turn_rate_deg_s : float
        Speed on the legs and turn rate on the spot (the approach to the end of each slows down).
    cmd_vel_topic, odom_topic : str
        The controller's velocity command and odometry topics.
    stamped : bool
        Publish ``geometry_msgs/msg/TwistStamped`` (stamped now) instead of
        ``geometry_msgs/msg/Twist``.
    pause_s : float
        Rest between two runs, in seconds.

    Returns
    -------
    str
        The script (Python 3, needs ``rclpy``, ``geometry_msgs`` and ``nav_msgs``).
    """
    check_run_plan(side_m, speed_m_s, turn_rate_deg_s, pause_s)
    if runs < 1:
        raise InputError(f"`runs` must be at least 1, not {runs!r}")
    for name, topic in (("cmd_vel_topic", cmd_vel_topic), ("odom_topic", odom_topic)):
        if not re.fullmatch(r"~?/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*", topic):
            raise InputError(f"`{name}` is not a ROS topic name: {topic!r}")
    values = {
        "SIDE_M": repr(float(side_m)),
        "RUNS": repr(int(runs)),
        "SPEED_M_S": repr(float(speed_m_s)),
        "TURN_RATE_RAD_S": repr(math.radians(turn_rate_deg_s)),
        "PAUSE_S": repr(float(pause_s)),
        "CMD_VEL_TOPIC": repr(cmd_vel_topic),
        "ODOM_TOPIC": repr(odom_topic),
        "STAMPED": repr(bool(stamped)),
    }
    text = _SCRIPT
    for key, value in values.items():
        text = text.replace(f"@@{key}@@", value)
    return text
