"""``umbmark bag-info``: the topics of a ROS bag, to choose the options that read it.

The library does the work (:func:`umbmark.io.rosbag.bag_info`); this module prints its
``to_dict()`` or a table made from it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import click

from umbmark.cli.app import app, cli_message, console, emit_json, fmt, is_quiet, table

if TYPE_CHECKING:
    from rich.console import Console

__all__ = ["bag_info_cmd"]


@app.command(name="bag-info")
@click.argument("bag")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bag_info_cmd(bag: str, as_json: bool) -> None:
    """List the topics of a ROS 1 or ROS 2 bag (to choose --joints, --gt-topic ...): types,
    message counts and rates, the joint names of JointState topics, the frames of poses,
    odometry, scans and transforms.

    \b
    Example:
      umbmark bag-info recording.bag
      umbmark bag-info rosbag2_2026_11_21/ --json
    """
    from umbmark.io.rosbag import bag_info

    info = bag_info(bag)
    if as_json:
        emit_json(info.to_dict())
    elif not is_quiet():
        c = console()
        c.print(
            table(
                f"{bag}: {info.messages} messages, {info.duration_s:.1f} s",
                ["topic", "type", "messages", "rate [Hz]", "joints / frames"],
                [[t.topic, t.type, t.messages, fmt(t.rate_hz, 1), t.describe()] for t in info.topics],
            )
        )
        for t in info.topics:
            if t.joint_names:
                _print_joint_flags(c, t.topic, t.joint_names)


def _print_joint_flags(c: Console, topic: str, names: Sequence[str]) -> None:
    """The joints of a JointState topic in the order each kind's flags want them (by their names)."""
    from rich.markup import escape

    from umbmark.kinds import joint_flags_for

    c.print(escape(f"The joints of {topic} as each kind's flags take them, in the order they want:"))
    for k, flags, found in joint_flags_for(names):
        kind = "" if k.differential else f"--kinematics {k.name} "
        how = "found by their names (check them)" if found else "the names do not tell which is which"
        c.print(escape(f"  {k.noun}: {kind}{cli_message(flags)}; {how}"), soft_wrap=True)
    c.print("selfcal sets the joints' motion against the lidar's and names another order that fits far better.")
