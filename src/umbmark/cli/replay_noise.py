"""``umbmark replay --noise``: the odometry's random error from the ground truth's residuals at
several interval lengths, and whether the per-metre model holds across them."""

from __future__ import annotations

from typing import Any

import click

from umbmark.cli.app import cli_message, console, fmt, table
from umbmark.errors import InputError

__all__ = ["replay_noise_cmd", "print_replay_noise"]


def _verdict(name: str, fit: dict[str, Any]) -> str | None:
    """A warning when the noise is not given as ``odometry_noise`` (model not holding across lengths)."""
    if fit.get("consistent"):
        return None

    def at(f: dict[str, Any]) -> str:
        n = f["noise"]
        left, right = n["wheel_sd_left_mm_per_sqrt_m"], n["wheel_sd_right_mm_per_sqrt_m"]
        return f"{left:.2f} / {right:.2f} mm/sqrt(m) over {f['stride_s']:g} s"

    first, last = fit["fits"][0], fit["fits"][-1]
    return (
        f"{name}: the odometry's noise from the ground truth depends on the interval length (left / right "
        f"wheel {at(first)}, {at(last)}): the residuals are not a random walk in distance (errors that "
        "persist over seconds, or a ground truth noisier than its fitted jitter); no odometry_noise is given "
        "for export (self-calibrate with the lidar for covariances)"
    )


def replay_noise_cmd(sets: list, rep: Any, d: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """Estimate each data set's noise and put it into its part of the replay JSON ``d``.

    Each part gains ``odometry_noise_strides`` (every length's fit, the verdict, the held-out
    NEES) and, when the model holds at every length, ``odometry_noise`` (the longest length's fit,
    what ``umbmark export`` turns into covariances); else a warning in its ``warnings``.

    Returns
    -------
    list of (str, dict)
        Each data set's name and its ``odometry_noise_strides`` with its ``warning`` (or only the
        warning when it has none), for the table.

    Raises
    ------
    InputError
        No data set's noise could be estimated.
    """
    from umbmark.realrobot.replay_noise import report_noise

    reports = list(getattr(rep, "reports", None) or [rep])
    parts = d["datasets"] if isinstance(d.get("datasets"), list) else [d]
    out, errors = [], []
    for ds, r, part in zip(sets, reports, parts):
        try:
            fit = report_noise(ds, r).to_dict()
        except InputError as e:
            errors.append(f"{ds.name}: {e.message}")
            part["odometry_noise_strides"] = {"error": e.message}
            part.setdefault("warnings", []).append(f"no odometry noise for {ds.name}: {e.message}")
            out.append((ds.name, {"warning": part["warnings"][-1]}))
            continue
        part["odometry_noise_strides"] = fit
        warning = _verdict(ds.name, fit)
        if warning is None:
            part["odometry_noise"] = fit["fits"][-1]["noise"]
        else:
            part.setdefault("warnings", []).append(warning)
        out.append((ds.name, {**fit, "warning": warning}))
    if len(errors) == len(out):
        raise InputError(f"no odometry noise: {errors[0]}")
    return out


def print_replay_noise(fits: list[tuple[str, dict[str, Any]]]) -> None:
    """Each data set's noise at every interval length: the wheels, the ground truth's timing and heading
    jitter, the held-out NEES at that length."""
    for name, fit in fits:
        if "fits" not in fit:
            click.echo(f"warning: {cli_message(fit['warning'])}", err=True)
            continue
        rows = []
        for i, f in enumerate(fit["fits"]):
            n = f["noise"]
            rows.append(
                [
                    fmt(f["stride_s"], 2),
                    f"{fmt(n['wheel_sd_left_mm_per_sqrt_m'], 2)} / {fmt(n['wheel_sd_right_mm_per_sqrt_m'], 2)}",
                    fmt(n.get("timing_sd_ms"), 1),
                    fmt(n.get("heading_jitter_mrad_at_1radps"), 1),
                    fmt(f["heldout_nees"][i], 2),
                ]
            )
        holds = "holds at every length" if fit["consistent"] else "does NOT hold across lengths"
        console().print(
            table(
                f"{name}: odometry noise from the ground truth (per-metre model {holds})",
                [
                    "interval [s]",
                    "wheel noise L / R [mm/sqrt(m)]",
                    "timing [ms]",
                    "heading jitter [mrad at 1 rad/s]",
                    "held-out NEES",
                ],
                rows,
            )
        )
        if fit.get("warning"):
            click.echo(f"warning: {cli_message(fit['warning'])}", err=True)
