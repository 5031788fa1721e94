"""``umbmark replay LOG.csv --stream``: replay one long log in bounded memory (printing part)."""

from __future__ import annotations

from umbmark.cli.app import console, emit_json, fmt, is_quiet, table

__all__ = ["run_stream"]


def run_stream(paths, kw: dict, decimate, poses_out, as_json) -> None:
    """Replay ``paths`` as one streamed log (:func:`umbmark.realrobot.replay.stream_log`) and print it.

    Parameters
    ----------
    paths : sequence of str
        The log files or folders.
    kw : dict
        The replay command's reader options (``log_format`` and the geometry).
    decimate : int or None
        Keep the pose after every N-th sample.
    poses_out : str or None
        CSV file for the kept poses (needs ``decimate``).
    as_json : bool
        Print one JSON object instead of the table.

    Raises
    ------
    InputError
        If ``poses_out`` is given without ``decimate``.
    """
    from umbmark.realrobot.replay import stream_log

    opts = {k: v for k, v in kw.items() if k not in ("log_format",)}
    rep = stream_log(list(paths), decimate=decimate, fmt=kw.get("log_format") or "auto", **opts)
    kept = rep.pop("kept", None)
    if kept is not None:
        rep["kept_poses"] = int(kept["sample"].size)
    if poses_out:
        if kept is None:
            from umbmark.errors import InputError

            raise InputError("--poses-out needs --decimate N (keep the pose after every N-th sample)")
        import numpy as np

        from umbmark.io.atomic import atomic_path

        with atomic_path(poses_out) as tmp:
            np.savetxt(
                tmp,
                np.column_stack([kept["sample"], kept["t_s"], kept["x_m"], kept["y_m"], kept["theta_rad"]]),
                delimiter=",",
                header="sample,time_s,x_m,y_m,theta_rad",
                comments="",
                fmt="%.10g",
            )
        rep["poses_out"] = str(poses_out)
    if as_json:
        emit_json(rep)
        return
    if is_quiet():
        return
    e, g = rep["end_pose"], rep["end_truth"] or {}
    rows = [
        ["x [mm]", fmt(e["x_mm"]), fmt(g.get("x_mm"))],
        ["y [mm]", fmt(e["y_mm"]), fmt(g.get("y_mm"))],
        ["theta [deg]", fmt(e["theta_deg"], 3), fmt(g.get("theta_deg"), 3)],
    ]
    c = console()
    c.print(
        table(
            f"{rep['dataset']}: {rep['samples']} samples, {rep['duration_s']:.1f} s, streamed in "
            f"{rep['chunks']} chunks",
            ["end pose", "odometry (nominal)", "ground truth"],
            rows,
        )
    )
    c.print(
        f"end position error {fmt(rep['end_position_error_mm'])} mm, along-path position RMS "
        f"{fmt(rep['path_position_rms_mm'])} mm"
    )
    if rep.get("poses_out"):
        c.print(f"wrote {rep['kept_poses']} poses to {rep['poses_out']}")
