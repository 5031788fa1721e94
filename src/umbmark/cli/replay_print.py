"""The tables and lines ``umbmark replay`` prints: a replay's report (one data set's, several's,
a pooled fit's), a streamed log's, the lidar's and the gyro's verdicts, the noise's and the
windows' tables.

They are made from the library's results (:mod:`umbmark.realrobot.results`); no numerical module
is imported before a command runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from umbmark.cli.app import cli_message, console, fmt, table
from umbmark.cli.history import print_recorded

if TYPE_CHECKING:
    from umbmark.realrobot.gyro import GyroReference
    from umbmark.realrobot.results import MultiReplayReport, PooledReport, ReplayReport, StreamReport
    from umbmark.realrobot.scan_truth import ScanTruth

__all__ = ["print_replay", "print_stream", "print_gyro"]


def _mm(v: float | None) -> float | None:
    return None if v is None else v * 1e3


def _escape(text: object) -> str:
    from rich.markup import escape

    return escape(str(text))


def _print_report(rep: ReplayReport) -> None:
    """A :class:`~umbmark.realrobot.results.ReplayReport` as tables."""
    c = console()
    sq = rep.kind == "square"
    path = f"square {rep.side_m * 1e3:.0f} mm" if sq and rep.side_m is not None else "general path"
    c.print(
        f"[bold]{_escape(rep.dataset)}[/bold] ({rep.format}, {len(rep.runs)} runs, {path}), method "
        f"[bold]{_escape(rep.method)}[/bold]"
    )
    h = rep.heldout.summary if rep.heldout is not None else None
    rows = []
    if sq:
        rows.append(
            [
                "E_max,syst [mm]",
                fmt(_mm(rep.before.emax_syst_m)),
                fmt(_mm(rep.after.emax_syst_m)),
                fmt(None if h is None else _mm(h.emax_syst_m)),
            ]
        )
    rows += [
        [
            "end position RMS [mm]",
            fmt(_mm(rep.before.end_position_rms_m)),
            fmt(_mm(rep.after.end_position_rms_m)),
            fmt(None if h is None else _mm(h.end_position_rms_m)),
        ],
        [
            "along-path position RMS [mm]",
            fmt(_mm(rep.before.path_position_rms_m)),
            fmt(_mm(rep.after.path_position_rms_m)),
            fmt(None if h is None else _mm(h.path_position_rms_m)),
        ],
    ]
    c.print(table("Replayed odometry vs ground truth", ["", "nominal", "calibrated (in-sample)", "held out"], rows))
    if rep.heldout is not None and rep.heldout.reason:
        c.print(f"held out: {rep.heldout.reason}")
    n, cal = rep.nominal, rep.calibration
    g = cal.geometry
    cal_rows = [
        ["D_L [mm]", fmt(n.diameter_left_m * 1e3, 4), fmt(g.diameter_left_m * 1e3, 4)],
        ["D_R [mm]", fmt(n.diameter_right_m * 1e3, 4), fmt(g.diameter_right_m * 1e3, 4)],
        ["wheelbase [mm]", fmt(n.wheelbase_m * 1e3, 3), fmt(g.wheelbase_m * 1e3, 3)],
        ["E_d = D_R/D_L", "1", fmt(cal.ed, 6)],
        ["E_b", "1", fmt(cal.eb, 6)],
        ["c_left / c_right", "1 / 1", f"{cal.c_left:.6f} / {cal.c_right:.6f}"],
        [
            "wheelbase / mean diameter",
            fmt(n.wheelbase_m / n.diameter_avg_m, 4),
            fmt(cal.wheelbase_per_mean_diameter, 4),
        ],
    ]
    lsq = cal.lsq
    if lsq is not None:
        cal_rows.append(["fitted", "", lsq.fitted_parameters])
    c.print(table("Calibration", ["", "nominal", "corrected"], cal_rows))
    if lsq is not None:
        c.print(f"scale: {lsq.scale_reason}")
        if lsq.marker_offset_m is not None and lsq.marker_offset_std_m is not None:
            off = [v * 1e3 for v in lsq.marker_offset_m]
            err = [v * 1e3 for v in lsq.marker_offset_std_m]
            c.print(
                f"tracked point offset from the axle midpoint: x {off[0]:.1f} +- {err[0]:.1f} mm, "
                f"y {off[1]:.1f} +- {err[1]:.1f} mm (robot frame)"
            )
        s = rep.std
        if s is not None:
            c.print(
                f"jackknife std: D_L {s.diameter_left_m * 1e3:.3f} mm, D_R {s.diameter_right_m * 1e3:.3f} mm, "
                f"b {s.wheelbase_m * 1e3:.3f} mm, E_d {s.ed:.5f}"
            )
    from rich.markup import escape

    for o in rep.time_offset:
        est = "not estimated" if o["estimated_s"] is None else f"estimated {o['estimated_s'] * 1e3:.1f} ms"
        where = o.get("bag") or f"{o.get('log')} {o.get('run')}"
        c.print(
            f"ground truth late by: {est}, {o['applied_s'] * 1e3:.1f} ms subtracted from its stamps "
            f"({escape(str(where))})"
        )
    from umbmark.cli.bags import stream_text

    for o in rep.wheel_stream:
        if o["clock"] != "as recorded" or o["kept"] != o["messages"]:
            c.print(escape(f"wheel data ({o['bag']}): {stream_text(o)}"))
    for w in rep.warnings:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")


def _print_pooled(rep: PooledReport) -> None:
    """A :class:`~umbmark.realrobot.results.PooledReport` as a table and a line."""
    c = console()
    rows = [
        [
            p.dataset,
            fmt(_mm(p.before.end_position_rms_m)),
            fmt(_mm(p.after.end_position_rms_m)),
            fmt(None if p.heldout is None else _mm(p.heldout.end_position_rms_m)),
        ]
        for p in rep.per_dataset
    ]
    c.print(
        table(
            "lsq fitted to all data sets: end-position RMS [mm]",
            ["data set", "nominal", "pooled fit", "held out (fit on the others)"],
            rows,
        )
    )
    g, cal = rep.calibration.geometry, rep.calibration
    assert cal.lsq is not None  # a pooled fit is the least squares'
    c.print(
        f"D_L = {g.diameter_left_m * 1e3:.3f} mm, D_R = {g.diameter_right_m * 1e3:.3f} mm, wheelbase = "
        f"{g.wheelbase_m * 1e3:.3f} mm, E_d = {cal.ed:.6f}, "
        f"fitted: {cal.lsq.fitted_parameters}"
    )


def _print_across(rep: MultiReplayReport) -> None:
    """The across-data-set rows of a :class:`~umbmark.realrobot.results.MultiReplayReport`."""
    rows = [
        [a.calibrated_on, a.evaluated_on, fmt(_mm(a.evaluation.emax_syst_m)), fmt(_mm(a.evaluation.end_position_rms_m))]
        for a in rep.across
    ]
    console().print(
        table(
            "Held out across data sets",
            ["calibrated on", "evaluated on", "E_max,syst [mm]", "end position RMS [mm]"],
            rows,
        )
    )


def print_stream(rep: StreamReport) -> None:
    """A :class:`~umbmark.realrobot.results.StreamReport` as a table and lines."""
    e, g = rep.end_pose, rep.end_truth or (None, None, None)
    rows = [
        ["x [mm]", fmt(e[0] * 1e3), fmt(_mm(g[0]))],
        ["y [mm]", fmt(e[1] * 1e3), fmt(_mm(g[1]))],
        ["theta [deg]", fmt(math.degrees(e[2]), 3), fmt(None if g[2] is None else math.degrees(g[2]), 3)],
    ]
    c = console()
    c.print(
        table(
            f"{rep.dataset}: {rep.samples} samples, {rep.duration_s:.1f} s, streamed in {rep.chunks} chunks",
            ["end pose", "odometry (nominal)", "ground truth"],
            rows,
        )
    )
    c.print(
        f"end position error {fmt(_mm(rep.end_position_error_m))} mm, along-path position RMS "
        f"{fmt(_mm(rep.path_position_rms_m))} mm"
    )
    if rep.poses_out is not None and rep.kept is not None:
        c.print(f"wrote {len(rep.kept)} poses to {rep.poses_out}", markup=False, soft_wrap=True)


def print_replay(
    rep: ReplayReport | MultiReplayReport | PooledReport,
    rec: dict | list | None,
    scan_truth: ScanTruth | None,
    gyro: GyroReference | None,
    windows: list[dict[str, Any]] | None = None,
    noise_fits: list[tuple[str, dict[str, Any]]] | None = None,
) -> None:
    """A replay's report as tables: a pooled fit, one data set's or several's; the lidar's and
    the gyro's lines; the noise's and the windows' tables."""
    from umbmark.realrobot.results import MultiReplayReport, PooledReport

    if isinstance(rep, PooledReport):
        _print_pooled(rep)
        print_recorded(rec)
        return
    print_recorded(rec)
    if isinstance(rep, MultiReplayReport):
        for r in rep.reports:
            _print_report(r)
        _print_across(rep)
    else:
        _print_report(rep)
    if scan_truth is not None:
        _print_scan_truth(scan_truth)
    if gyro is not None:
        print_gyro(gyro)
    if noise_fits:
        from umbmark.cli.replay_noise import print_replay_noise

        print_replay_noise(noise_fits)
    if windows is not None:
        from umbmark.cli.replay_windows import print_replay_windows

        print_replay_windows(windows)


def _print_scan_truth(st: ScanTruth) -> None:
    """One line on how the lidar measured the runs."""
    kept = [r for r in st.runs if r.displacement is not None]
    x, y, yaw = st.sensor_pose
    line = (
        f"lidar ground truth ({st.scan_topic}): {len(kept)} of {len(st.runs)} runs measured, the lidar at "
        f"x {x * 1e3:.1f} mm, y {y * 1e3:.1f} mm, yaw {math.degrees(yaw):.2f} deg ({st.sensor_pose_source})"
    )
    if kept:
        rms = [r.rms_m * 1e3 for r in kept]
        frac = [r.inlier_fraction for r in kept]
        line += f"; residual {min(rms):.1f} to {max(rms):.1f} mm RMS, {min(frac):.0%} or more of each end scan matched"
    console().print(line)


def print_gyro(g: GyroReference) -> None:
    """The gyro's verdict as a table and lines."""
    from rich.markup import escape

    def ci(p: Sequence[float] | None, f: Callable[[float], str], k: float = 1.0) -> str:
        return "-" if p is None else f"{f(p[0] * k)} .. {f(p[1] * k)}"

    rows = [
        [
            "wheelbase [mm]",
            fmt(g.nominal_wheelbase_m * 1e3, 2),
            fmt(g.wheelbase_m * 1e3, 2),
            ci(g.wheelbase_m_ci95, lambda v: fmt(v, 2), 1e3),
        ],
        ["E_b (wheel_separation_multiplier)", "1", fmt(g.eb, 5), ci(g.eb_ci95, lambda v: fmt(v, 5))],
        [f"gyro scale ({g.gyro_scale_source})", "1", fmt(g.gyro_scale, 5), ci(g.gyro_scale_ci95, lambda v: fmt(v, 5))],
    ]
    c = console()
    used = sum(t.used for t in g.turns)
    c.print(
        table(
            f"Gyro {g.imu_topic}: {used} turns used of {len(g.turns)}", ["", "nominal", "gyro", "95 % interval"], rows
        )
    )
    c.print(
        f"bias {math.degrees(g.bias_radps):.4f} deg/s removed (measured over {g.still_s:.1f} s at rest), "
        f"noise {fmt(math.degrees(g.noise_radps), 4)} deg/s per reading"
    )
    for w in g.warnings:
        c.print(f"[yellow]warning:[/yellow] {escape(cli_message(w))}")
