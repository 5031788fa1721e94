"""``umbmark replay --window DURATION``: the runs of a long recording grouped into windows of
time, each replayed and calibrated (and recorded with its own date)."""

from __future__ import annotations

from typing import Any

from umbmark.cli.app import console, fmt, table
from umbmark.cli.selfcal_windows import record_windows

__all__ = ["replay_windows_cmd", "print_replay_windows"]


def replay_windows_cmd(
    sets: list, window_s: float, method: str, lsq_opts: dict, heldout: bool, paths: list, history: tuple
) -> tuple[list[dict], list]:
    """Replay the windows of each data set; record each calibrated one when asked.

    Returns
    -------
    tuple
        The windows' JSON (each with its ``history`` record when recorded), and the records.
    """
    from umbmark.history import file_sha256
    from umbmark.realrobot.replay import history_fields
    from umbmark.realrobot.replay_windows import replay_windows

    def fields_of(w: Any) -> tuple[dict, str]:
        (fields,) = history_fields(w.report, paths, kind="replay", method=method, file_hash=file_sha256)
        return fields, w.dataset

    wins = [w for ds in sets for w in replay_windows(ds, window_s, method, lsq_opts, heldout)]
    return record_windows(wins, window_s, "calibrated", fields_of, history)


def print_replay_windows(windows: list[dict[str, Any]]) -> None:
    """The windows as a table: when, the runs, E_d, E_b, the wheelbase, the errors before and after."""
    rows = []
    for w in windows:
        r = w["result"]
        when = w["start_utc"][:19].replace("T", " ")
        if r is None:
            rows.append([w["window"] + 1, when, len(w["runs"]), "-", "-", "-", w["error"]])
            continue
        before, after = r.get("before") or {}, r.get("after") or {}
        err = "emax_syst_mm" if before.get("emax_syst_mm") is not None else "end_position_rms_mm"
        rows.append(
            [
                w["window"] + 1,
                when,
                len(w["runs"]),
                fmt(r.get("Ed"), 6),
                fmt(r.get("Eb"), 6),
                fmt(r.get("wheelbase_corrected_mm"), 2),
                f"{fmt(before.get(err), 1)} -> {fmt(after.get(err), 1)} mm",
            ]
        )
    console().print(
        table(
            "Windows (each calibrated on its own runs)",
            ["#", "start (UTC)", "runs", "E_d", "E_b", "wheelbase [mm]", "error before -> after / why not"],
            rows,
        )
    )
