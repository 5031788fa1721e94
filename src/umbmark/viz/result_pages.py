"""The HTML pages of a calibration loop (``umbmark calibrate``) and of a gyro's verdict on the
wheelbase (``umbmark replay --imu-topic``): one self-contained page each, as the other reports
(figures embedded, the style inline).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from umbmark.viz.report import (
    _UMBMARK_DEFINITIONS,
    _e,
    _header,
    _img,
    _load_section,
    _page,
    _table,
    _warnings_list,
    figure_data_uri,
)
from umbmark.viz.text import fmt, interval95

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["is_calibrate_result", "is_gyro_result", "calibrate_page", "gyro_page", "GYRO_DEFINITIONS"]

#: What the figures of a gyro's verdict mean.
GYRO_DEFINITIONS = (
    "Each turn runs from the middle of one still period to the middle of the next. Wheels: the turn of the "
    "nominal wheel odometry (travel difference over the nominal wheelbase); gyro: the integrated rate, the bias "
    "measured at rest removed; true: whole turns or the lidar, where known. The effective "
    "wheelbase makes the wheels' turns agree with the gyro's (scaled by the gyro's scale factor when it is "
    "measured); E_b = effective / nominal wheelbase, the wheel_separation_multiplier of diff_drive_controller."
)


def is_calibrate_result(d: Any) -> bool:
    """Whether ``d`` is the JSON of ``umbmark calibrate`` (or a calibrate record's results)."""
    return isinstance(d, dict) and isinstance(d.get("passes"), list) and isinstance(d.get("final_calibration"), dict)


def is_gyro_result(d: Any) -> bool:
    """Whether ``d`` is the JSON of ``umbmark replay --imu-topic`` without a ground truth."""
    return isinstance(d, dict) and isinstance(d.get("gyro"), dict) and "before" not in d


def _num(v: Any) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else None


def _f(v: Any, digits: int = 1, times: float = 1.0) -> str:
    """A JSON value as a number with ``digits`` decimals (times ``times``), or "-"."""
    x = _num(v)
    return fmt(None if x is None else x * times, digits)


def _ci(d: dict[str, Any], key: str, digits: int, scale: float = 1.0) -> str:
    lo_hi = interval95(d, key + "_ci95")
    if lo_hi is None:
        return "-"
    return f"[{_f(lo_hi[0], digits, scale)}, {_f(lo_hi[1], digits, scale)}]"


# ---------------------------------------------------------------- calibrate


def passes_figure(passes: list[dict[str, Any]]) -> Figure:
    """E_max,syst of each pass against the paper's stopping rule (3 x SEM), on a log scale."""
    from umbmark.viz.plots import new_figure

    fig = new_figure((6.4, 3.2))
    ax = fig.add_subplot()
    k = np.arange(1, len(passes) + 1)
    emax = np.array([_num(p.get("emax_syst_mm")) or np.nan for p in passes])
    sem3 = np.array([_num(p.get("three_sem_mm")) or np.nan for p in passes])
    ax.bar(k, emax, color="#4a7ab5", label="E_max,syst")
    ax.plot(k, sem3, "o--", color="#c33", label="3 x SEM (stop below)")
    ax.set_yscale("log")
    ax.set_xticks(k)
    ax.set_xlabel("pass")
    ax.set_ylabel("mm")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("The return error of each pass")
    fig.tight_layout()
    return fig


def _count(n: object, one: str, many: str | None = None) -> str:
    """``1 pass``, ``2 passes``, ``? corrections``: a count and its noun, escaped."""
    return f"{_e(n)} {one if n == 1 else (many or one + 's')}"


def calibrate_page(
    d: dict[str, Any],
    *,
    title: str | None = None,
    source: str | None = None,
    source_sha256: str | None = None,
    robot: str | None = None,
    when: str | None = None,
    load_commands: str | None = None,
) -> str:
    """The HTML page of a calibration loop: its passes, the stopping rule, the calibration to load.

    Parameters
    ----------
    d : dict
        Its JSON (:meth:`umbmark.studies.iterate.LoopResult.to_dict`).
    title, source, source_sha256, robot, when, load_commands
        As for :func:`umbmark.viz.selfcal_report.selfcal_page`.

    Returns
    -------
    str
        One self-contained HTML document.
    """
    title = title or "Calibration loop report"
    body = _header(title, when, robot, f"result {source}" if source else None, source_sha256)
    passes = [p for p in d["passes"] if isinstance(p, dict)]
    final = d["final_calibration"]
    method = d.get("method", "?")
    body.append(
        f"<p>{_count(len(passes), 'pass', 'passes')}, {_count(d.get('corrections', '?'), 'correction')} "
        f"({_e(method)}); "
        f"{_e(d.get('stopped', ''))}.</p>"
    )
    body.append(
        '<div class="box"><p class="big">'
        f"c_left = {_e(_f(final.get('c_left'), 6))}, c_right = {_e(_f(final.get('c_right'), 6))}, "
        f"wheelbase = {_e(_f(final.get('wheelbase_mm'), 2))} mm</p>"
        f"<p>E_d = {_e(_f(final.get('Ed'), 6))}: the calibration to load (every pass's correction composed)</p></div>"
    )
    rows = []
    for p in passes:
        used = p.get("calibration_used") or {}
        c = p.get("correction") or {}
        src = p.get("source")
        rows.append(
            [
                f"{p.get('pass', '?')}" + (f" ({src})" if src else ""),
                f"{_f(used.get('c_left'), 5)} / {_f(used.get('c_right'), 5)}",
                _f(used.get("wheelbase_mm"), 2),
                _f(p.get("emax_syst_mm"), 1),
                _f(p.get("three_sem_mm"), 1),
                _f(c.get("Ed"), 6) if c else "-",
                _f(c.get("wheelbase_corrected_mm"), 2) if c else "-",
                _ci(c, "wheelbase_corrected_mm", 2) if c else "-",
            ]
        )
    body.append("<h2>Passes</h2>")
    body.append(
        _table(
            [
                "pass",
                "c_left / c_right used",
                "wheelbase used [mm]",
                "E_max,syst [mm]",
                "3 x SEM [mm]",
                "E_d (total)",
                "wheelbase new [mm]",
                "95 % [mm]",
            ],
            rows,
        )
    )
    body.append("<ul>" + "".join(f"<li>pass {_e(p.get('pass'))}: {_e(p.get('decision', ''))}</li>" for p in passes))
    body.append("</ul>")
    if passes:
        body.append(
            "<p>A pass is corrected while its E_max,syst is at least 3 x SEM (the paper's rule): below it the "
            "return errors are mostly noise and a further correction is unlikely to help.</p>"
        )
        body.append(_img(figure_data_uri(passes_figure(passes)), "E_max,syst of each pass"))
    true = d.get("true")
    if isinstance(true, dict):
        body.append("<h2>The simulated robot</h2>")
        body.append(
            _table(
                ["", "true", "calibrated"],
                [
                    ["E_d", _f(true.get("Ed"), 6), _f(final.get("Ed"), 6)],
                    ["wheelbase [mm]", _f(true.get("wheelbase_mm"), 2), _f(final.get("wheelbase_mm"), 2)],
                ],
            )
        )
    warnings = [
        f"pass {p.get('pass')}: {w}"
        for p in passes
        for w in ((p.get("correction") or {}).get("warnings") or [])
        if isinstance(w, str)
    ]
    body.append("<h2>Warnings</h2>")
    body.append(_warnings_list(warnings))
    body.extend(_load_section(d, source, load_commands, (("ros2", "params.yaml (ROS 2)"), ("firmware", "firmware"))))
    body.append(f'<h2>Definitions</h2><p class="meta">{_UMBMARK_DEFINITIONS}</p>')
    return _page(title, "\n".join(body))


# ---------------------------------------------------------------- gyro


def turns_figure(g: dict[str, Any]) -> Figure:
    """Each turn's gyro over wheel odometry ratio (the wheelbase factor it alone implies), with the fit."""
    from umbmark.viz.plots import new_figure

    turns = [t for t in g.get("turns") or [] if isinstance(t, dict)]
    fig = new_figure((6.4, 3.2))
    ax = fig.add_subplot()
    scale = _num(g.get("gyro_scale")) or 1.0
    for used, marker, label in ((True, "o", "used"), (False, "x", "not used")):
        k, ratio = [], []
        for i, t in enumerate(turns, 1):
            w, gy = _num(t.get("wheels_deg")), _num(t.get("gyro_deg"))
            if bool(t.get("used")) == used and w and gy is not None and abs(gy) > 0:
                k.append(i)
                ratio.append(w / (gy / scale))
        if k:
            ax.plot(k, ratio, marker, color="#4a7ab5" if used else "#c33", label=label, linestyle="none")
    eb = _num(g.get("Eb"))
    if eb is not None:
        ax.axhline(eb, color="#333", lw=1, label=f"E_b = {eb:.5f}")
    ci = interval95(g, "Eb_ci95")
    if ci is not None:
        ax.axhspan(ci[0], ci[1], color="#999", alpha=0.25, lw=0, label="95 %")
    ax.set_xlabel("turn")
    ax.set_ylabel("wheels' turn / gyro's turn")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("The wheelbase factor each turn implies")
    fig.tight_layout()
    return fig


def gyro_page(
    d: dict[str, Any],
    *,
    title: str | None = None,
    source: str | None = None,
    source_sha256: str | None = None,
    robot: str | None = None,
    when: str | None = None,
) -> str:
    """The HTML page of a gyro's verdict on the wheelbase (and the gyro's own scale).

    Parameters
    ----------
    d : dict
        Its JSON: ``{"gyro": ..., "warnings": [...]}`` of ``umbmark replay --imu-topic ... --save``
        (:meth:`umbmark.realrobot.gyro.GyroReference.to_dict`).
    title, source, source_sha256, robot, when
        As for :func:`umbmark.viz.selfcal_report.selfcal_page`.

    Returns
    -------
    str
        One self-contained HTML document.
    """
    g = d["gyro"]
    title = title or "Gyro report"
    body = _header(title, when, robot, f"result {source}" if source else None, source_sha256)
    turns = [t for t in g.get("turns") or [] if isinstance(t, dict)]
    used = sum(bool(t.get("used")) for t in turns)
    body.append(
        f"<p>The gyro {_e(g.get('imu_topic', '?'))}: {used} of {len(turns)} turns used; the bias measured over "
        f"{_e(_f(g.get('still_s'), 1))} s at rest ({_e(g.get('readings', '?'))} readings).</p>"
    )
    body.append(
        '<div class="box"><p class="big">'
        f"wheelbase = {_e(_f(g.get('wheelbase_m'), 2, 1e3))} mm, E_b = {_e(_f(g.get('Eb'), 5))}</p>"
        f"<p>wheel_separation_multiplier = {_e(_f(g.get('wheel_separation_multiplier'), 5))} (with "
        f"wheel_separation {_e(_f(g.get('nominal_wheelbase_m'), 4))} m)</p></div>"
    )
    body.append("<h2>Estimates</h2>")
    src = g.get("gyro_scale_source", "assumed")
    body.append(
        _table(
            ["", "nominal", "gyro", "95 % interval"],
            [
                [
                    "wheelbase [mm]",
                    _f(g.get("nominal_wheelbase_m"), 2, 1e3),
                    _f(g.get("wheelbase_m"), 2, 1e3),
                    _ci(g, "wheelbase_m", 2, 1e3),
                ],
                ["E_b (wheel_separation_multiplier)", "1", _f(g.get("Eb"), 5), _ci(g, "Eb", 5)],
                [f"gyro scale ({src})", "1", _f(g.get("gyro_scale"), 5), _ci(g, "gyro_scale", 5)],
            ],
        )
    )
    bias, noise = _num(g.get("bias_rad_per_s")), _num(g.get("noise_rad_per_s"))
    if bias is not None and noise is not None:
        body.append(
            f"<p>Bias {_e(_f(math.degrees(bias), 4))} deg/s removed; noise {_e(_f(math.degrees(noise), 4))} "
            "deg/s per reading at rest.</p>"
        )
    body.append("<h2>The turns</h2>")
    starts = [_num((t.get("t_s") or [None])[0]) for t in turns]
    t0 = min((s for s in starts if s is not None), default=0.0)
    rows = []
    for i, t in enumerate(turns, 1):
        span = t.get("t_s") or [None, None]
        a, b = (_num(x) for x in (span + [None, None])[:2])
        rows.append(
            [
                i,
                "-" if a is None or b is None else f"{_f(a - t0, 2)} to {_f(b - t0, 2)}",
                _f(t.get("wheels_deg"), 2),
                _f(t.get("gyro_deg"), 2),
                "-" if t.get("true_deg") is None else _f(t.get("true_deg"), 2),
                _f(t.get("travel_mm"), 1),
                "yes" if t.get("on_the_spot") else "no",
                "yes" if t.get("used") else "no",
            ]
        )
    body.append(
        _table(
            ["turn", "from, to [s]", "wheels [deg]", "gyro [deg]", "true [deg]", "travel [mm]", "on the spot", "used"],
            rows,
        )
    )
    body.append('<p class="meta">Times in seconds after the start of the first turn.</p>')
    if turns:
        body.append(_img(figure_data_uri(turns_figure(g)), "the wheelbase factor of each turn"))
    warnings = [w for w in (d.get("warnings") or g.get("warnings") or []) if isinstance(w, str)]
    body.append("<h2>Warnings</h2>")
    body.append(_warnings_list(warnings))
    body.append("<h2>Load it into the robot</h2>")
    body.append(
        "<pre>"
        + _e(
            "# diff_drive_controller (ROS 2 params.yaml)\n"
            f"wheel_separation: {_f(g.get('nominal_wheelbase_m'), 4)}\n"
            f"wheel_separation_multiplier: {_f(g.get('wheel_separation_multiplier'), 5)}"
        )
        + "</pre>"
    )
    body.append(
        '<p class="meta">The gyro sees the wheelbase only: the wheel radius multipliers stay as they are (measure '
        "them with selfcal, or with replay and a ground truth).</p>"
    )
    body.append(f'<h2>Definitions</h2><p class="meta">{_e(GYRO_DEFINITIONS)}</p>')
    return _page(title, "\n".join(body))
