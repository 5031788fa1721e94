"""Self-contained HTML reports: one analysis, or one robot's calibration history.

The page has no external references: the figures are PNGs embedded as base64 ``data:`` URIs and
the style sheet is inline, so the file can be mailed or archived alone.

Intervals shown (95 %):

* centres of gravity ``x_cg``, ``y_cg``: Student-t interval ``mean +- t(0.975, n-1) * s / sqrt(n)``
  per direction and axis;
* E_d, E_b, the corrected wheelbase, c_left, c_right: percentile bootstrap over the runs
  (resampled with replacement within each direction, the correction recomputed with the same
  method; ``bootstrap`` resamples, seeded). If the correction method itself reports
  ``*_ci95`` values, those are shown as well.
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Callable, Iterable, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from umbmark._version import __version__
from umbmark.errors import CorrectionUndefined, InputError
from umbmark.kinds import KINDS, Kind, kind_in
from umbmark.viz.text import fmt, interval95

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from umbmark.correct.analysis import Analysis
    from umbmark.correct.result import CorrectionResult
    from umbmark.history.base import Record
    from umbmark.model.geometry import Calibration
    from umbmark.model.runs import RunsTable

__all__ = [
    "analysis_report",
    "history_report",
    "figure_data_uri",
    "bootstrap_intervals",
    "cg_intervals",
    "default_bootstrap",
    "exact_resample_options",
    "replay_analysis",
    "SELFCAL_DEFINITIONS",
]

#: What the figures of a self-calibration mean (its page and the history page print it).
SELFCAL_DEFINITIONS = (
    "D_L, D_R: the wheel diameters, and the wheelbase: the effective distance between the wheels, that make "
    "the wheel odometry move as the lidar saw the robot move (Censi et al., IEEE T-RO 2013). E_d = D_R / D_L; "
    "E_b = wheelbase / nominal wheelbase. c_left = D_L / D_nominal, c_right = D_R / D_nominal: the factors on "
    "each wheel's travel (the wheel radius multipliers of diff_drive_controller). The lidar's pose: x forward "
    "and y to the left of the midpoint between the wheels, yaw counter-clockwise from the robot's heading. "
    "Residual: the lidar's measured displacement over an interval minus the one the estimate predicts from "
    "the wheels, in the lidar's frame at the interval's start."
)

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:2em auto;max-width:60em;
     color:#222;line-height:1.45;padding:0 1em}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:1.8em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;margin:.6em 0;font-size:.9em}.scroll{overflow-x:auto}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
.meta{color:#555;font-size:.9em}.box{background:#eef6ee;border:1px solid #9c9;padding:.6em 1em;display:inline-block}
.warn{color:#a40}img{max-width:100%;height:auto;border:1px solid #eee}pre{background:#f7f7f7;padding:.6em;
     white-space:pre-wrap;overflow-wrap:anywhere;font-size:.85em}.big{font-size:1.3em;font-weight:bold}
body.wide{max-width:75em}table.records{font-size:.8em}table.records td{white-space:nowrap}
table.records th{white-space:normal}table.records td.src{white-space:normal;overflow-wrap:anywhere;max-width:14em}
"""


def _header(title: str, when: str | None, robot: str | None, source: str | None, sha256: str | None) -> list[str]:
    """A page's title and its line of where and when it was made."""
    when = when or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    meta = [f"generated {when} by umbmark {__version__}"]
    if robot:
        meta.insert(0, f"robot {robot}")
    if source:
        meta.append(source + (f" (sha256 {sha256[:16]}\u2026)" if sha256 else ""))
    return [f"<h1>{_e(title)}</h1>", f'<p class="meta">{" &middot; ".join(_e(m) for m in meta)}</p>']


def figure_data_uri(fig: Figure, dpi: int = 100) -> str:
    """A figure as a ``data:image/png;base64,...`` URI, to embed in a page.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; released afterwards (:func:`umbmark.viz.plots.close_figure`).
    dpi : int
        Resolution of the PNG.

    Returns
    -------
    str
    """
    from umbmark.viz.plots import close_figure

    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=dpi)
    finally:
        close_figure(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _e(v: object) -> str:
    return html.escape(str(v), quote=True)


def _ci(lo_hi: Sequence[float | None] | None, digits: int) -> str:
    if not lo_hi or lo_hi[0] is None or lo_hi[1] is None:
        return "-"
    return f"[{fmt(lo_hi[0], digits)}, {fmt(lo_hi[1], digits)}]"


def _table(
    header: Sequence[object],
    rows: Iterable[Sequence[object]],
    cls: str | None = None,
    col_cls: dict[int, str] | None = None,
) -> str:
    col_cls = col_cls or {}

    def cell(tag: str, j: int, c: object) -> str:
        k = col_cls.get(j)
        return f'<{tag} class="{k}">{_e(c)}</{tag}>' if k else f"<{tag}>{_e(c)}</{tag}>"

    h = "".join(cell("th", j, c) for j, c in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", j, c) for j, c in enumerate(r)) + "</tr>" for r in rows)
    attr = f' class="{cls}"' if cls else ""
    return f'<div class="scroll"><table{attr}><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table></div>'


def _img(uri: str, alt: str) -> str:
    return f'<p><img src="{uri}" alt="{_e(alt)}"></p>'


def _warnings_list(items: list[str]) -> str:
    """A page's warnings as a list ("No warnings." when there are none)."""
    if not items:
        return "<p>No warnings.</p>"
    return "<ul>" + "".join(f'<li class="warn">{_e(w)}</li>' for w in items) + "</ul>"


def _load_section(
    d: dict[str, Any],
    source: str | None,
    commands: str | None,
    formats: tuple[tuple[str, str], ...],
    read: Callable[[dict[str, Any], str], Any] | None = None,
    write: Callable[[Any, str], str] | None = None,
) -> list[str]:
    """The commands that load a result into the robot, and the texts they write: ``formats``
    holds (export format, label) pairs; ``read`` makes the calibration of the result's JSON and
    ``write`` its text in a format (a differential drive's by default:
    :func:`umbmark.io.export.calibration_from_dict`, :func:`umbmark.io.export.format_export`)."""
    from umbmark.errors import InputError
    from umbmark.io.export import calibration_from_dict, format_export

    read, write = read or calibration_from_dict, write or format_export
    out = ["<h2>Load it into the robot</h2>"]
    if commands:
        out.append(f"<pre>{_e(commands)}</pre>")
        out.append('<p class="meta">The texts below are what those commands write for this result.</p>')
    try:
        cal = read(d, source or "<result>")
        for fmt_name, label in formats:
            out.append(f"<h3>{_e(label)}</h3><pre>{_e(write(cal, fmt_name))}</pre>")
    except InputError as e:
        out.append(f'<p class="warn">The export of this result fails: {_e(e)}</p>')
    return out


def _page(title: str, body: str, body_cls: str | None = None) -> str:
    attr = f' class="{body_cls}"' if body_cls else ""
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f'<meta name="generator" content="umbmark {_e(__version__)}">\n'
        f"<title>{_e(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body{attr}>\n{body}\n</body>\n</html>\n"
    )


def cg_intervals(runs: RunsTable, level: float = 0.95) -> dict[str, dict[str, tuple[float | None, float | None]]]:
    """Student-t intervals of the centres of gravity of the return errors, per direction and axis.

    Parameters
    ----------
    runs : RunsTable
        The runs.
    level : float
        Confidence level.

    Returns
    -------
    dict
        ``{"cw": {"x": (lo, hi), "y": (lo, hi)}, "ccw": {...}}`` in millimetres; ``(None, None)``
        for a direction with fewer than 2 runs.
    """
    from umbmark._stats import t_ppf

    out: dict[str, dict[str, tuple[float | None, float | None]]] = {}
    for d in ("cw", "ccw"):
        rows = runs.direction_rows(d)
        n = len(rows)
        out[d] = {}
        for axis, eps in (("x", rows.eps_x), ("y", rows.eps_y)):
            m = float(np.mean(eps)) * 1e3
            if n < 2:
                out[d][axis] = (None, None)
                continue
            half = t_ppf(0.5 + level / 2, n - 1) * float(np.std(eps, ddof=1)) / math.sqrt(n) * 1e3
            out[d][axis] = (m - half, m + half)
    return out


# Cost of one bootstrap resample of method exact [s]: a + b * runs, measured on one core by
# ``python benchmarks/exact_scale.py`` (benchmarks/results/exact_scale.md, "bootstrap").
EXACT_RESAMPLE_COST_S = (0.0030, 1.01e-5)
BOOTSTRAP_BUDGET_S = 10.0
BOOTSTRAP_RESAMPLES = 1000
BOOTSTRAP_MIN_RESAMPLES = 200


def exact_resample_options(full: CorrectionResult) -> dict[str, Any]:
    """The options of method ``exact`` for the bootstrap's resamples.

    A resample lies next to the runs, so the answer's basin is the one to look in: each is
    fitted from the answer on all runs, with its heading weight, without the global search,
    without intervals, with analytic Jacobians and the compiled model.

    Parameters
    ----------
    full : CorrectionResult
        Method ``exact`` on all runs.

    Returns
    -------
    dict
        Keyword options of :func:`umbmark.correct.exact.exact_correction`.
    """
    from umbmark.correct.result import ExactFit

    options: dict[str, Any] = {
        "_start": (full.ed_pass, full.eb),
        "global_search": False,
        "_intervals": False,
        "_fast": True,
    }
    if isinstance(full.details, ExactFit) and full.details.heading_weight_m is not None:
        options["heading_weight_m"] = full.details.heading_weight_m
    return options


def default_bootstrap(method: str, n_runs: int) -> tuple[int, str | None]:
    """How many bootstrap resamples a report makes by default, and why none where none.

    ``bf``: 1000. ``exact``: 1000 where they take under 10 s by the measured cost of one
    resample (:data:`EXACT_RESAMPLE_COST_S`), else as many as fit in 10 s (in hundreds), and
    none where fewer than 200 would. Other methods: none (they may report their own
    intervals).

    Parameters
    ----------
    method : str
        The correction method.
    n_runs : int
        The number of runs.

    Returns
    -------
    n_boot : int
        The resamples (0: no bootstrap).
    note : str or None
        For ``exact`` without the full 1000: what was done and why, for the report.
    """
    if method == "bf":
        return BOOTSTRAP_RESAMPLES, None
    if method != "exact":
        return 0, None
    a, b = EXACT_RESAMPLE_COST_S
    each = a + b * n_runs
    fit = int(BOOTSTRAP_BUDGET_S / each) // 100 * 100
    if fit >= BOOTSTRAP_RESAMPLES:
        return BOOTSTRAP_RESAMPLES, None
    if fit >= BOOTSTRAP_MIN_RESAMPLES:
        return fit, (
            f"bootstrap with {fit} resamples instead of {BOOTSTRAP_RESAMPLES}: one resample of exact on "
            f"{n_runs} runs takes about {each * 1e3:.0f} ms, and the default bootstrap stays under "
            f"{BOOTSTRAP_BUDGET_S:.0f} s"
        )
    return 0, (
        f"bootstrap skipped: {BOOTSTRAP_MIN_RESAMPLES} resamples of exact on {n_runs} runs would take about "
        f"{BOOTSTRAP_MIN_RESAMPLES * each:.0f} s (more than {BOOTSTRAP_BUDGET_S:.0f} s); the method's own "
        "intervals are shown (give the number of resamples to bootstrap anyway)"
    )


def bootstrap_intervals(
    runs: RunsTable,
    side_m: float,
    wheelbase_m: float,
    method: str = "bf",
    prior: Calibration | None = None,
    n_boot: int = 1000,
    seed: int = 0,
    level: float = 0.95,
    advance: Callable[[], object] | None = None,
    center: CorrectionResult | None = None,
) -> dict[str, Any]:
    """Percentile bootstrap intervals of Ed, Eb, wheelbase_mm, c_left, c_right.

    The runs are resampled with replacement within each direction and the correction is
    recomputed with the same method on each resample. Method ``exact``: each resample is
    fitted as :func:`exact_resample_options` says.

    Parameters
    ----------
    runs : RunsTable
        The runs.
    side_m, wheelbase_m : float
        Side of the square and the wheelbase the odometry used.
    method : str
        The correction method.
    prior : Calibration, optional
        The calibration the robot ran with.
    n_boot : int
        Number of resamples.
    seed : int
        Seed of the resampling.
    level : float
        Confidence level.
    advance : callable, optional
        Called once per resample (for a progress bar).
    center : CorrectionResult, optional
        A calibration of the same runs found with more than the runs table holds (a replay
        result's, which knew the odometry's end poses): the resampled values are shifted by
        its difference from the method on the runs table, so the intervals sit about it.

    Returns
    -------
    dict
        ``{"n_boot", "failed", "seed", "level", "Ed": (lo, hi), "Eb", "wheelbase_mm", "c_left",
        "c_right"}``; ``failed`` counts resamples where the correction is undefined (they are
        left out); an interval is ``(None, None)`` with fewer than 10 defined resamples. With
        ``center``: ``shift``, the difference added to each key.
    """
    from umbmark.correct import correct_runs

    def values(c: CorrectionResult) -> dict[str, float]:
        return {
            "Ed": c.ed,
            "Eb": c.eb,
            "wheelbase_mm": _corrected_wheelbase_m(c.calibration) * 1e3,
            "c_left": c.calibration.c_left,
            "c_right": c.calibration.c_right,
        }

    options: dict[str, Any] = {}
    shift: dict[str, float] | None = None
    if method == "exact" or center is not None:
        full = correct_runs(method, runs, side_m, wheelbase_m, prior)
        if method == "exact":  # each resample fitted from the answer on all runs: see exact_resample_options
            options = exact_resample_options(full)
        if center is not None:
            shift = {k: values(center)[k] - v for k, v in values(full).items()}
    rng = np.random.default_rng(seed)
    idx = {d: np.flatnonzero(runs.direction == d) for d in ("cw", "ccw")}
    keys = ("Ed", "Eb", "wheelbase_mm", "c_left", "c_right")
    vals: dict[str, list[float]] = {k: [] for k in keys}
    failed = 0
    for _ in range(n_boot):
        pick = np.concatenate([rng.choice(idx[d], size=idx[d].size, replace=True) for d in ("cw", "ccw")])
        try:
            c = correct_runs(method, runs.select(pick), side_m, wheelbase_m, prior, **options)
        except CorrectionUndefined:
            failed += 1
        else:
            for k, v in values(c).items():
                vals[k].append(v + (shift[k] if shift else 0.0))
        if advance is not None:
            advance()
    out: dict[str, Any] = {"n_boot": n_boot, "failed": failed, "seed": seed, "level": level}
    if shift is not None:
        out["shift"] = shift
    q = [50 * (1 - level), 100 - 50 * (1 - level)]
    for k in keys:
        out[k] = tuple(float(v) for v in np.percentile(vals[k], q)) if len(vals[k]) >= 10 else (None, None)
    return out


def _replay_runs(block: object, what: str, source: str) -> RunsTable:
    """The runs table of a replay result's ``before`` or ``after`` block: its return errors
    (truth minus odometry) as the absolute end poses of an odometry that closed."""
    from umbmark.errors import InputError
    from umbmark.model.runs import RunsTable

    rows = block.get("runs") if isinstance(block, dict) else None
    if not isinstance(rows, list) or not rows:
        raise InputError(f"the replay result has no runs {what} calibration", source=source)
    try:
        eps = np.array([[float(r["eps_x_mm"]), float(r["eps_y_mm"])] for r in rows]) * 1e-3
        theta = np.radians([float(r["end_heading_error_deg"]) for r in rows])
        direction = [str(r["direction"]) for r in rows]
        names = [str(r["run"]) for r in rows]
    except (KeyError, TypeError, ValueError):
        raise InputError(
            f"the replay result's runs {what} calibration have no return errors (eps_x_mm, eps_y_mm, direction): "
            "a replay of square runs is needed",
            source=source,
        ) from None
    zero = np.zeros(len(rows))
    return RunsTable.from_columns(direction, eps[:, 0], eps[:, 1], zero, zero, theta, zero, run=names)


def replay_analysis(result: dict[str, Any], source: str = "<replay>") -> tuple[Analysis, RunsTable | None]:
    """The analysis a ``replay`` result holds: its runs, its calibration, its runs after it.

    The result (the JSON ``umbmark replay --save`` writes) holds each run's return error
    before and after calibration and the calibration the replay found; the report shows
    these as they are (no refit). The runs table is the return errors of an odometry that
    closed (the result does not hold the odometry's end poses): the centres of gravity, the
    scatter and the bootstrap of ``bf`` are those of the replay's runs.

    Parameters
    ----------
    result : dict
        The replay result.
    source : str
        The file it came from (for messages).

    Returns
    -------
    analysis : umbmark.correct.analysis.Analysis
        The runs before calibration, their figures and the replay's calibration.
    after : RunsTable or None
        The runs replayed with the calibration.

    Raises
    ------
    InputError
        Not a replay result of square runs, or one without its calibration or geometry.
    """
    from umbmark.correct.analysis import Analysis
    from umbmark.correct.result import CorrectionResult
    from umbmark.errors import InputError
    from umbmark.metrics import umbmark_figures

    if isinstance(result, dict) and {"cw", "ccw", "emax_syst_mm"} <= result.keys():
        made_from = result.get("file")
        raise InputError(
            "an analysis result holds the figures, not the runs: report the runs file it was made from"
            + (f" ({made_from})" if isinstance(made_from, str) and made_from else ""),
            source=source,
        )
    if isinstance(result, dict) and result.get("pooled") and isinstance(result.get("datasets"), list):
        raise InputError(
            f"a pooled replay (one lsq fit of {len(result['datasets'])} data sets together) holds no runs of one "
            "test to show: replay one data set of square runs without pooling, save it and report that (its "
            "calibration exports as it is)",
            source=source,
        )
    if isinstance(result, dict) and isinstance(result.get("datasets"), list) and "method" in result:
        raise InputError(
            f"a replay of {len(result['datasets'])} data sets: replay the one to show on its own, save it and "
            "report that",
            source=source,
        )
    own = kind_in(result)
    if own is not None:  # (its self-calibration has a page of its own: umbmark.viz.kind_report)
        raise InputError(
            f"a {own.noun}'s replay against a ground truth (`kinematics={own.name}`): the report draws a "
            f"{own.noun}'s self-calibration and a differential drive's square runs; the command's table holds this "
            f"one's figures, and its export (`fmt=\"ros2\"`) writes the {own.controller}'s parameters",
            source=source,
        )
    if not isinstance(result, dict) or "before" not in result or "method" not in result:
        raise InputError(
            "not a result the report can show (the JSON a replay or a self-calibration saves)", source=source
        )
    if result.get("kind") != "square":
        gyro = (
            " and the gyro's check (for that, report a replay with `imu_topic` and without `gt_topic`)"
            if ("gyro" in result)
            else ""
        )
        raise InputError(
            f"a replay along a general path (method {result.get('method')}){gyro}: the report shows UMBmark "
            "square runs; the command's table and JSON hold this one's figures, its calibration exports as it is "
            '(`fmt="ros2"`), or replay square runs (`side_mm`) and report those',
            source=source,
        )
    try:
        side_m = float(result["side_mm"]) * 1e-3
        wheelbase_m = float(result["nominal"]["wheelbase_mm"]) * 1e-3
        # the calibration's keys of the result, the method's own of its correction block
        calibration = {k: result[k] for k in ("method", "Ed", "Eb", "c_left", "c_right", "wheelbase_corrected_mm")}
        correction = CorrectionResult.from_dict(
            {**dict(result.get("correction") or {}), **calibration}, warnings=result.get("warnings") or ()
        )
    except (KeyError, TypeError, ValueError):
        raise InputError(
            "the replay result has no calibration (Ed, Eb, c_left, c_right, wheelbase_corrected_mm, side_mm, "
            "nominal.wheelbase_mm)",
            source=source,
        ) from None
    runs = _replay_runs(result["before"], "before", source)
    after = _replay_runs(result["after"], "after", source) if isinstance(result.get("after"), dict) else None
    return Analysis(runs, umbmark_figures(runs), correction, side_m, wheelbase_m), after


def _analysis_sections(
    analysis: Analysis, boot: dict[str, Any] | None, prior: Calibration | None = None, boot_note: str | None = None
) -> str:
    """The return errors, the correction and the recommended parameters of one analysis, as HTML."""
    d = analysis.to_dict()
    parts = (
        _errors_section(analysis, d)
        + _correction_section(analysis, d)
        + _parameters_section(analysis, d, boot, prior, boot_note)
    )
    for w in d.get("warnings", []):
        parts.append(f'<p class="warn">Warning: {_e(w)}</p>')
    return "\n".join(parts)


def _errors_section(analysis: Analysis, d: dict[str, Any]) -> list[str]:
    """The return errors per direction with Student-t intervals, E_max,syst and the 3 x SEM rule."""
    res = analysis.result
    runs = analysis.runs
    ci = cg_intervals(runs)
    rows = []
    for st in (res.cw, res.ccw):
        s = st.to_dict()
        rows.append(
            [
                st.direction,
                st.n,
                fmt(s["x_cg_mm"]),
                _ci(ci[st.direction]["x"], 1),
                fmt(s["y_cg_mm"]),
                _ci(ci[st.direction]["y"], 1),
                fmt(s["r_cg_mm"]),
                fmt(s["std_mm"]),
                fmt(s["sem_mm"]),
            ]
        )
    parts = [
        "<h2>UMBmark return position errors</h2>",
        "<p>Return position error of each run: absolute minus odometry (Eq. 3.1), in the start frame "
        "(x along the first leg, y to the left), millimetres. 95 % intervals: Student-t.</p>",
        _table(["direction", "n", "x_cg", "x_cg 95 %", "y_cg", "y_cg 95 %", "r_cg", "std (radial)", "SEM"], rows),
    ]
    rule = "-" if d["three_sem_mm"] is None else f"{d['three_sem_mm']:.1f} mm"
    parts.append(
        f'<p class="big">E<sub>max,syst</sub> = {fmt(d["emax_syst_mm"])} mm</p>'
        f"<p>3 &times; SEM = {_e(rule)}; a further compensation pass is "
        f"{'recommended' if d['second_pass_recommended'] else 'not expected to help'} "
        f"(E<sub>max,syst</sub> {'&ge;' if d['second_pass_recommended'] else '&lt;'} 3 SEM).</p>"
    )
    return parts


def _correction_section(analysis: Analysis, d: dict[str, Any]) -> list[str]:
    """The method, and for a linear correction its angles and factors from x, from y and used."""
    corr = analysis.correction
    parts = [f"<h2>Correction (method {_e(corr.method)})</h2>"]
    if corr.alpha is not None:
        crow = [
            ["alpha [deg]", fmt(d.get("alpha_x_deg"), 4), fmt(d.get("alpha_y_deg"), 4), fmt(d.get("alpha_deg"), 4)],
            ["beta [deg]", fmt(d.get("beta_x_deg"), 4), fmt(d.get("beta_y_deg"), 4), fmt(d.get("beta_deg"), 4)],
            ["E_d (this pass)", fmt(d.get("Ed_x"), 6), fmt(d.get("Ed_y"), 6), fmt(d.get("Ed_pass"), 6)],
            ["E_b", fmt(d.get("Eb_x"), 6), fmt(d.get("Eb_y"), 6), fmt(d.get("Eb"), 6)],
        ]
        parts.append(_table(["", "from x", "from y", "used"], crow))
    return parts


def _corrected_wheelbase_m(cal: Calibration) -> float:
    """The wheelbase of a correction's calibration (every correction method sets it)."""
    assert cal.wheelbase_m is not None, "a correction's calibration holds the corrected wheelbase"
    return cal.wheelbase_m


def _parameters_section(
    analysis: Analysis,
    d: dict[str, Any],
    boot: dict[str, Any] | None,
    prior: Calibration | None,
    boot_note: str | None = None,
) -> list[str]:
    """The parameters to load into the odometry, with the bootstrap's and the method's intervals."""
    corr = analysis.correction
    cal = corr.calibration
    wheelbase_mm = _corrected_wheelbase_m(cal) * 1e3
    parts = []
    b = boot or {}
    prow = [
        ["E_d = D_R / D_L", fmt(corr.ed, 6), _ci(b.get("Ed"), 6)],
        ["E_b", fmt(corr.eb, 6), _ci(b.get("Eb"), 6)],
        ["c_left", fmt(cal.c_left, 6), _ci(b.get("c_left"), 6)],
        ["c_right", fmt(cal.c_right, 6), _ci(b.get("c_right"), 6)],
        ["wheelbase [mm]", fmt(wheelbase_mm, 2), _ci(b.get("wheelbase_mm"), 2)],
    ]
    for k, v in d.items():
        if k.endswith("_ci95") and isinstance(v, (list, tuple)) and len(v) == 2:
            prow.append([f"{k} (method)", "", _ci(v, 6)])
    used = (
        f"c_left = {fmt(prior.c_left, 6)}, c_right = {fmt(prior.c_right, 6)}, "
        if prior is not None
        else "c_left = c_right = 1 (uncalibrated), "
    )
    parts.append(
        '<h2>Recommended parameters</h2><div class="box">'
        f"<p>Load into the odometry: <b>c_left = {fmt(cal.c_left, 6)}</b>, "
        f"<b>c_right = {fmt(cal.c_right, 6)}</b>, <b>wheelbase = {fmt(wheelbase_mm, 2)} mm</b>.</p>"
        f"<p>The runs were made with {used}wheelbase = {fmt(analysis.wheelbase_m * 1e3, 2)} mm; "
        f"square side {fmt(analysis.side_m * 1e3, 0)} mm.</p></div>"
    )
    hdr = ["", "value", "95 % bootstrap" if boot else "interval"]
    parts.append(_table(hdr, prow))
    if boot:
        parts.append(
            f'<p class="meta">Bootstrap: {b["n_boot"]} resamples of the runs within each direction '
            f"(seed {b['seed']}); {b['failed']} resamples had no defined correction. With few runs per "
            "direction the bootstrap intervals are rough.</p>"
        )
    if boot_note:
        parts.append(f'<p class="meta bootnote">{_e(boot_note[0].upper() + boot_note[1:])}.</p>')
    return parts


def analysis_report(
    analysis: Analysis,
    *,
    title: str | None = None,
    source: str | None = None,
    source_sha256: str | None = None,
    prior: Calibration | None = None,
    after_runs: RunsTable | None = None,
    trajectories: Sequence[dict[str, Any]] | None = None,
    exported: dict[str, str] | None = None,
    boot: dict[str, Any] | None = None,
    robot: str | None = None,
    when: str | None = None,
    boot_note: str | None = None,
) -> str:
    """HTML page of one analysis: the UMBmark figures, the correction, the recommended
    parameters with intervals, the scatter plot and the definitions.

    Parameters
    ----------
    analysis : umbmark.correct.analysis.Analysis
        The analysis.
    title : str, optional
        The page's title (default: "UMBmark report").
    source : str, optional
        The input's name, and ``source_sha256`` its content hash, shown in the header.
    source_sha256 : str, optional
        See ``source``.
    prior : Calibration, optional
        The calibration the robot ran with.
    after_runs : RunsTable, optional
        Runs after calibration (drawn filled in the scatter).
    trajectories : list of dict, optional
        Paths to draw (see :func:`umbmark.viz.plots.trajectory_figure`).
    exported : dict, optional
        File name -> text of exported parameter files (shown verbatim).
    boot : dict, optional
        :func:`bootstrap_intervals` of the analysis.
    robot : str, optional
        The robot's name, shown in the header.
    when : str, optional
        When the page was made (default: now, UTC).
    boot_note : str, optional
        Why the bootstrap was skipped or shortened (:func:`default_bootstrap`).

    Returns
    -------
    str
        The page: one self-contained HTML document.
    """
    from umbmark.metrics import umbmark_figures
    from umbmark.viz.plots import scatter_figure, trajectory_figure

    title = title or "UMBmark report"
    body = _header(title, when, robot, f"input {source}" if source else None, source_sha256)
    body.append(_analysis_sections(analysis, boot, prior, boot_note))
    body.append("<h2>Return position errors: scatter</h2>")
    if after_runs is not None:
        after = umbmark_figures(after_runs)
        body.append(
            f"<p>Before: E<sub>max,syst</sub> = {fmt(analysis.result.emax_syst * 1e3)} mm; after: "
            f"{fmt(after.emax_syst * 1e3)} mm (improvement "
            f"{fmt(analysis.result.emax_syst / after.emax_syst if after.emax_syst > 0 else math.inf)}-fold)."
            "</p>"
        )
    fig = scatter_figure(analysis.runs, after_runs, title=title)
    body.append(_img(figure_data_uri(fig), "return position error scatter"))
    if trajectories:
        body.append("<h2>Trajectories</h2>")
        body.append(
            _img(figure_data_uri(trajectory_figure(trajectories, title="True and odometry paths")), "trajectories")
        )
    if exported:
        body.append("<h2>Exported files</h2>")
        for name, text in exported.items():
            body.append(f"<h3>{_e(name)}</h3><pre>{_e(text)}</pre>")
    body.append(_definitions())
    return _page(title, "\n".join(body))


_UMBMARK_DEFINITIONS = (
    "Return position error eps = absolute &minus; odometry "
    "(Eq. 3.1); centre of gravity per direction (Eq. 3.2), r_cg its distance from the origin; "
    "E<sub>max,syst</sub> = max(r_cg,cw, r_cg,ccw) (Eq. 3.4). std: radial sample standard deviation "
    "of the return errors about their centre of gravity; SEM = std / sqrt(n). E_d = D_R / D_L, "
    "E_b = b_actual / b_nominal, c_left = 2 / (E_d + 1), c_right = 2 / (1/E_d + 1) (Borenstein &amp; "
    "Feng, Eqs. 4.20 &ndash; 4.32)."
)


def _definitions_of(r: Record) -> str:
    """Whose definitions a record needs: ``umbmark``, ``selfcal`` or a kind's name (its self-calibration)."""
    own = kind_in(r.results)
    return own.name if own is not None else "selfcal" if r.method == "selfcal" else "umbmark"


def _definitions(kinds: set[str] | None = None) -> str:
    """The Definitions section: UMBmark's, and the self-calibration's when ``kinds`` holds it (a
    kind's name: the words of that kind of robot's, :attr:`umbmark.kinds.Kind.legend`)."""

    if kinds is None or kinds == {"umbmark"}:
        return f'<h2>Definitions</h2><p class="meta">{_UMBMARK_DEFINITIONS}</p>'
    parts = []
    if "umbmark" in kinds:
        parts.append(f'<p class="meta"><b>Square runs (analyze, replay, calibrate):</b> {_UMBMARK_DEFINITIONS}</p>')
    if "selfcal" in kinds:
        parts.append(f'<p class="meta"><b>Self-calibrations:</b> {_e(SELFCAL_DEFINITIONS)}</p>')
    for k in (KINDS[n] for n in KINDS if n in kinds):  # another kind of robot's self-calibrations
        parts.append(f'<p class="meta"><b>{_e(k.title)}:</b> {_e(" ".join(k.legend))}</p>')
    return "<h2>Definitions</h2>" + "".join(parts)


def _selfcal_table(records: Iterable[Record]) -> str:
    """One row per self-calibration record: its diameters, wheelbase and lidar pose with intervals."""

    def cell(d: dict[str, Any], key: str, digits: int) -> str:
        v = d.get(key)
        ci = interval95(d, f"{key}_ci95")
        if not isinstance(v, (int, float)):
            return "-"
        if ci is not None:
            return f"{fmt(v, digits)} [{fmt(ci[0], digits)}, {fmt(ci[1], digits)}]"
        return fmt(v, digits)

    rows = []
    for r in records:
        d = r.results if isinstance(r.results, dict) else {}
        sp = d.get("sensor_pose")
        if not isinstance(sp, dict):
            sp = {}
        delays = [x.get("applied_s") for x in (d.get("scan_delay") or []) if isinstance(x, dict)]
        delay = ", ".join(fmt(x * 1e3, 1) for x in delays if isinstance(x, (int, float))) or "-"
        rows.append(
            [
                f"#{r.id}",
                r.created_utc[:19].replace("T", " "),
                cell(d, "wheel_diameter_left_mm", 3),
                cell(d, "wheel_diameter_right_mm", 3),
                cell(d, "wheelbase_mm", 2),
                f"{fmt(sp.get('x_mm'), 1)}, {fmt(sp.get('y_mm'), 1)}, {fmt(sp.get('yaw_deg'), 2)}",
                f"{d.get('intervals_used', '-')} / {len(d.get('intervals_rejected') or [])}",
                delay,
            ]
        )
    return _table(
        [
            "id",
            "time (UTC)",
            "D_L [mm] [95 %]",
            "D_R [mm] [95 %]",
            "wheelbase [mm] [95 %]",
            "lidar x, y [mm], yaw [deg]",
            "intervals used / rejected",
            "scans' delay [ms]",
        ],
        rows,
        cls="records",
    )


def _estimate_cell(v: float | None, ci: tuple[float, float] | None, digits: int) -> str:
    """A value and its 95 % interval in one cell (``-`` without a value)."""
    if v is None:
        return "-"
    return fmt(v, digits) + ("" if ci is None else f" [{fmt(ci[0], digits)}, {fmt(ci[1], digits)}]")


def _kind_selfcal_table(records: Iterable[Record], own: Kind) -> str:
    """One row per self-calibration record of a robot of a kind of its own: each parameter it
    estimated and the lidar pose, with intervals."""
    recs = list(records)
    got: list[dict[str, tuple[float | None, tuple[float, float] | None]]] = [
        {p.name: (v, ci) for p, v, ci in own.estimates_json(r.results)} for r in recs
    ]
    params = [p for p in own.parameters if any(g.get(p.name, (None, None))[1] is not None for g in got)]
    rows = []
    for r, g in zip(recs, got):
        d = r.results
        sp = d.get("sensor_pose")
        sp = sp if isinstance(sp, dict) else {}
        rows.append(
            [
                f"#{r.id}",
                r.created_utc[:19].replace("T", " "),
                *(_estimate_cell(*g.get(p.name, (None, None)), p.digits) for p in params),
                f"{fmt(sp.get('x_mm'), 1)}, {fmt(sp.get('y_mm'), 1)}, {fmt(sp.get('yaw_deg'), 2)}",
                f"{d.get('intervals_used', '-')} / {len(d.get('intervals_rejected') or [])}",
            ]
        )
    head = [f"{p.table_label} [95 %]" for p in params]
    return _table(["id", "time (UTC)", *head, "lidar x, y [mm], yaw [deg]", "intervals used / rejected"], rows)


def _records_table(records: Iterable[Record]) -> str:
    """One row per record: id, time, kind, method, the figures and the parameters, its input."""
    rows = []
    for r in records:
        p = r.parameters
        src = Path(r.source).name if r.source else (r.input_sha256 or "-")[:12]
        own = kind_in(p)
        rows.append(
            [
                f"#{r.id}",
                r.created_utc[:19].replace("T", " "),
                f"{r.kind}/{r.method}" + ("" if own is None else f" ({own.noun})"),
                fmt(r.emax_syst_mm),
                fmt(r.ed, 6),
                fmt(r.eb, 6),
                fmt(r.wheelbase_mm, 2),
                fmt(p.get("c_left"), 6),
                fmt(p.get("c_right"), 6),
                r.software_version,
                src,
            ]
        )
    return _table(
        [
            "id",
            "time (UTC)",
            "kind/ method",
            "E_max,syst [mm]",
            "E_d",
            "E_b",
            "wheelbase [mm]",
            "c_left",
            "c_right",
            "umbmark",
            "input",
        ],
        rows,
        cls="records",
        col_cls={10: "src"},
    )


def _drift_section(records: Sequence[Record]) -> list[str]:
    """Wear and changes of the history (:func:`umbmark.history.drift.detect_drift`), when some
    parameter has enough sessions."""
    from umbmark.history.drift import detect_drift
    from umbmark.viz.drift_plot import drift_figure

    try:
        rep = detect_drift(records, robot=records[0].robot)
    except InputError:
        return []  # no record holds a parameter with its interval: nothing to follow
    if not rep.trends:
        return []
    out = [
        "<h2>Drift</h2>",
        f"<p>Each parameter of the {_e(rep.kind)} records over its {rep.sessions} sessions: one wear rate per "
        "day, and steps where the sessions' intervals cannot hold one line (false-alarm rate "
        f"{rep.false_alarm_rate:g} per parameter; <code>umbmark drift</code> checks the same).</p>",
    ]
    if rep.changes:
        out.append(
            '<div class="box">'
            + "".join(
                f'<p class="warn"><b>{_e(c.parameter)}</b> changed at record #{c.record} ({_e(c.time_utc[:16])}): '
                f"{fmt(c.before, 6)} &rarr; {fmt(c.after, 6)} (step {fmt(c.step, 6)}, 95 % interval "
                f"{fmt(c.step_ci95[0], 6)} .. {fmt(c.step_ci95[1], 6)})</p>"
                for c in rep.changes
            )
            + "</div>"
        )
    else:
        out.append("<p>No change: every parameter follows one trend within its intervals.</p>")
    rows = [
        [
            name,
            t.sessions,
            fmt(t.latest, 6),
            fmt(t.rate_per_day, 6),
            "-"
            if t.rate_per_day_ci95 is None
            else f"{fmt(t.rate_per_day_ci95[0], 6)} .. {fmt(t.rate_per_day_ci95[1], 6)}",
        ]
        for name, t in rep.trends.items()
    ]
    out.append(_table(["parameter", "sessions", "latest", "rate per day", "95 % interval"], rows))
    out.append(_img(figure_data_uri(drift_figure(rep)), "drift plot"))
    return out


def history_report(records: Sequence[Record], *, title: str | None = None, db_path: str | None = None) -> str:
    """HTML page of one robot's calibration history: the records, the history figure, the
    latest recommended parameters and the latest runs.

    Parameters
    ----------
    records : list of Record
        One robot's records, oldest first.
    title : str, optional
        The page's title (default: "Calibration history of ROBOT").
    db_path : str, optional
        The database, shown in the header.

    Returns
    -------
    str
        The page: one self-contained HTML document.

    Raises
    ------
    ValueError
        If there are no records.
    """
    from umbmark.history import export_parameters, runs_from_rows
    from umbmark.viz.history_plot import history_figure
    from umbmark.viz.plots import scatter_figure

    if not records:
        raise ValueError("no records")
    robot = records[0].robot
    title = title or f"Calibration history of {robot}"
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    meta = [f"{len(records)} records", f"generated {when} by umbmark {__version__}"]
    if db_path:
        meta.append(f"database {db_path}")
    body = [f"<h1>{_e(title)}</h1>", f'<p class="meta">{" &middot; ".join(_e(m) for m in meta)}</p>']
    body.append("<h2>Records</h2>")
    body.append(_records_table(records))
    selfcals = [r for r in records if r.method == "selfcal" and isinstance(r.results, dict)]
    if selfcals:
        body.append("<h2>Self-calibrations</h2>")
        body.append(
            "<p>The geometry (the wheel diameters, wheelbase, and another kind of robot's own parameters) and "
            "lidar pose each self-calibration found, with their 95 % intervals (each record also has a page of "
            "its own, by its id).</p>"
        )
        diff_drives = [r for r in selfcals if kind_in(r.results) is None]
        if diff_drives:
            body.append(_selfcal_table(diff_drives))
        for own in dict.fromkeys(k for r in selfcals if (k := kind_in(r.results)) is not None):
            body.append(f"<h3>{_e(own.title)}</h3>")
            body.append(_kind_selfcal_table([r for r in selfcals if kind_in(r.results) is own], own))
    body.append("<h2>Over time</h2>")
    body.append(_img(figure_data_uri(history_figure(records)), "history plot"))
    body += _drift_section(records)
    latest = records[-1]
    ex = export_parameters(latest)
    body.append("<h2>Latest recommended parameters</h2>")
    extra = ""
    if latest.method == "selfcal" and isinstance(latest.results, dict):
        d = latest.results
        sp = d.get("sensor_pose")
        if not isinstance(sp, dict):
            sp = {}
        extra = (
            f"<p>D_L = {fmt(d.get('wheel_diameter_left_mm'), 3)} mm, D_R = {fmt(d.get('wheel_diameter_right_mm'), 3)}"
            f" mm; the lidar at x = {fmt(sp.get('x_mm'), 1)} mm, y = {fmt(sp.get('y_mm'), 1)} mm, yaw = "
            f"{fmt(sp.get('yaw_deg'), 2)} deg.</p>"
        )
    latest_kind = kind_in(latest.parameters)
    if latest_kind is not None:
        loaded = ", ".join(f"{k} = {v!r}" for k, v in ex["controller_parameters"].items())
        body.append(
            f'<div class="box"><p>Record #{latest.id} ({_e(latest.created_utc)}), a {_e(latest_kind.noun)}: '
            f"<b>{_e(latest_kind.describe_json(latest.parameters))}</b>.</p>"
            f"<p>{_e(latest_kind.controller)}: {_e(loaded)}</p></div>"
        )
    else:
        body.append(
            f'<div class="box"><p>Record #{latest.id} ({_e(latest.created_utc)}): '
            f"<b>c_left = {fmt(ex['c_left'], 6)}</b>, <b>c_right = {fmt(ex['c_right'], 6)}</b>, "
            f"<b>wheelbase = {fmt(ex['corrected_wheelbase_mm'], 2)} mm</b>.</p>{extra}</div>"
        )
    runs_rows = latest.inputs.get("runs") if isinstance(latest.inputs, dict) else None
    if runs_rows:
        try:
            runs = runs_from_rows(runs_rows)
            body.append("<h2>Latest runs</h2>")
            body.append(
                _img(figure_data_uri(scatter_figure(runs, title=f"{robot}: record #{latest.id}")), "latest scatter")
            )
        except Exception:  # noqa: BLE001  a malformed stored input must not stop the report
            body.append('<p class="warn">The latest record\'s runs could not be drawn.</p>')
    body.append(_definitions({_definitions_of(r) for r in records}))
    return _page(title, "\n".join(body), body_cls="wide")
