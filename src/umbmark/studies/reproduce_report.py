"""Figures and a self-contained HTML report of the paper reproduction. No printing.

:func:`study_figures` builds the figures of a :class:`~umbmark.studies.reproduce.Study`;
:func:`write_report` writes them (PNG and SVG) and ``index.html`` (figures embedded as base64
PNG, so the page stands alone; the files beside it are for reuse) into a folder.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
from pathlib import Path

from umbmark._version import __version__
from umbmark.errors import InputError
from umbmark.io.atomic import atomic_write
from umbmark.studies.reproduce import FIG11_ERRORS, PAPER_SEM_MM, PAPER_SIGMA_MM, PAPER_TABLE_I, Study, run_trajectories
from umbmark.viz.plots import distribution_figure, exaggerated_trajectory_figure, pitfall_figure, scatter_figure
from umbmark.viz.text import fmt

__all__ = [
    "FIGURES",
    "study_figures",
    "save_study_figures",
    "save_figure_keep_open",
    "write_report",
    "render_html",
    "table_rows",
]

# name -> (title, explanation)
FIGURES = {
    "scatter": (
        "Return position errors before and after calibration (like the paper's Fig. 11)",
        "Experiment 1 (the Fig. 11 robot), default seed. Open markers: the 5 cw (squares) and 5 ccw "
        "(circles) return position errors eps = absolute - odometry of the uncalibrated robot, with "
        "their centres of gravity (x). Filled markers and +: the same robot after one pass of the "
        "paper's correction. The clusters move from hundreds of mm to the noise around the origin.",
    ),
    "trajectories": (
        "True and odometry paths of one cw and one ccw run (like the paper's Figs. 3-5)",
        "The uncalibrated Fig. 11 robot, default seed. Dashed: what the odometry computes (close to the "
        "nominal square, since the controller drives on its own odometry); solid: where the robot really "
        "went. The odometry does not see the curvature of the legs (unequal wheels) nor the turn errors "
        "(wrong wheelbase); in cw they partly cancel, in ccw they add up.",
    ),
    "pitfall": (
        "The uni-directional pitfall (the paper's section 3.1, Figs. 3-4)",
        "An experimenter tunes only the wheelbase b, by trial and error, until the cw runs close well "
        "(grid of wheelbases, 5 cw runs each, the same run seeds for each trial). (a) The cw error "
        "goes through a sharp minimum, at a wheelbase that is not the true one: the wrong wheelbase "
        "(a Type A error) now cancels the curved legs (Type B) in cw. The ccw runs, which the "
        "experimenter never made, would have shown a large error there. (b) The bi-directional test of "
        "the tuned robot: cw excellent, ccw far off; UMBmark with the paper's correction brings both "
        "directions to the noise.",
    ),
    "distribution": (
        "The study over all seeds",
        "Every experiment of every seed: E_max,syst after one correction pass and after the "
        "rule-driven second pass, and the final improvement factor, against the paper's Table I "
        "(dashed red). The shaded band is the paper's 12-35 mm.",
    ),
}


def _paper_final(p):
    return p["second_mm"] if p["second_mm"] is not None else p["after_mm"]


def study_figures(study: Study, exaggerate: float = 1.0) -> dict:
    """The study's figures, keyed as :data:`FIGURES` (``pitfall`` only when the study has it).

    Parameters
    ----------
    study : Study
        The study.
    exaggerate : float
        Magnification of the deviation of the true paths in the trajectory figure.

    Returns
    -------
    dict
        Name -> :class:`matplotlib.figure.Figure`.

    Raises
    ------
    InputError
        If ``exaggerate`` is not a positive finite number.
    """
    if not (isinstance(exaggerate, (int, float)) and math.isfinite(exaggerate) and exaggerate > 0):
        raise InputError(f"exaggeration must be a positive number, got {exaggerate!r}")
    cfg = study.config
    e1 = study.experiments[0]
    figs = {}
    figs["scatter"] = scatter_figure(
        e1.before_runs,
        e1.first.runs,
        title=f"Experiment 1 (Fig. 11 robot), seed {cfg.seed}: E_max,syst {e1.emax_before * 1e3:.0f} mm -> "
        f"{e1.emax_after * 1e3:.0f} mm",
    )
    traj = run_trajectories(FIG11_ERRORS, None, cfg)
    ex = f", deviation exaggerated x{exaggerate:g}" if exaggerate != 1 else ""
    figs["trajectories"] = exaggerated_trajectory_figure(
        traj, exaggerate, cfg.side_m, title=f"Uncalibrated Fig. 11 robot, one cw and one ccw run{ex}"
    )
    if study.pitfall is not None:
        figs["pitfall"] = pitfall_figure(study.pitfall)
    d = study.distribution
    figs["distribution"] = distribution_figure(
        d.emax_before * 1e3,
        d.emax_after * 1e3,
        d.emax_final * 1e3,
        d.improvement_final,
        paper_after_mm=[_paper_final(p) for p in PAPER_TABLE_I],
        paper_improvement=[p["before_mm"] / _paper_final(p) for p in PAPER_TABLE_I],
        title=f"{d.emax_before.size} simulated experiments ({len(d.seeds)} seeds x 8)",
    )
    return figs


def save_study_figures(figs: dict, out_dir, formats=("png", "svg")) -> dict:
    """Save each figure as ``<name>.<format>`` in a folder, and release the figures.

    Parameters
    ----------
    figs : dict
        Name -> figure (:func:`study_figures`).
    out_dir : str or Path
        An existing folder.
    formats : tuple of str
        The formats to write (PNG at 110 dpi; SVG with stable bytes).

    Returns
    -------
    dict
        Name -> ``{format: path}``, plus the PNG bytes under ``"_png"`` (for embedding).
    """
    out_dir = Path(out_dir)
    paths: dict[str, dict[str, bytes | Path]] = {}
    for name, fig in figs.items():
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        png = buf.getvalue()
        paths[name] = {"_png": png}
        for kind in formats:
            if kind == "png":
                p = out_dir / f"{name}.png"
                atomic_write(p, png)
            else:
                p = out_dir / f"{name}.{kind}"
                save_figure_keep_open(fig, p)
            paths[name][kind] = p
        _close(fig)
    return paths


def save_figure_keep_open(fig, path) -> Path:
    """Write a figure atomically in the format its suffix names (110 dpi), leaving it open.

    An SVG has no date and fixed element ids: the same figure gives the same bytes.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or Path
        The file.

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib

    buf = io.BytesIO()
    kind = Path(path).suffix.lstrip(".")
    # no date and fixed element ids: the same study gives the same SVG bytes
    with matplotlib.rc_context({"svg.hashsalt": "umbmark-reproduce"}):
        fig.savefig(buf, format=kind, dpi=110, metadata={"Date": None} if kind == "svg" else None)
    atomic_write(path, buf.getvalue())
    return Path(path)


def _close(fig):
    from umbmark.viz.plots import close_figure

    close_figure(fig)


def table_rows(study: Study) -> list[dict]:
    """Table I side by side with the paper: one dict of display strings per experiment.

    Parameters
    ----------
    study : Study
        The study.

    Returns
    -------
    list of dict
        One dict per experiment, keyed as the columns of the page's Table I (``id``, ``ed``,
        ``b``, ``before``, ``paper_before``, ..., ``comment``).
    """
    rows = []
    for e, p in zip(study.experiments, PAPER_TABLE_I):
        d = e.to_dict()
        sp = d["second_pass"]
        rows.append(
            {
                "id": str(e.id),
                "ed": f"{e.errors.ed:.5f}",
                "b": f"{d['true_wheelbase_mm']:.2f}",
                "before": fmt(d["emax_before_mm"], 0),
                "paper_before": fmt(p["before_mm"], 0),
                "after": fmt(d["emax_after_mm"]),
                "paper_after": fmt(p["after_mm"], 0),
                "three_sem": fmt(d["three_sem_after_mm"]),
                "rule": "2nd pass" if d["second_pass_recommended"] else "stop",
                "second": "-" if sp is None else fmt(sp["emax_after_mm"]),
                "paper_second": "-" if p["second_mm"] is None else fmt(p["second_mm"], 0),
                "improvement": f"{d['improvement_final']:.1f}-fold",
                "paper_improvement": p["improvement"],
                "comment": p["comment"],
            }
        )
    return rows


_COLUMNS = [
    ("id", "exp."),
    ("ed", "true E<sub>d</sub>"),
    ("b", "true b [mm]"),
    ("before", "E<sub>max,syst</sub> before [mm]"),
    ("paper_before", "paper"),
    ("after", "after 1st pass [mm]"),
    ("paper_after", "paper"),
    ("three_sem", "3&times;SEM after [mm]"),
    ("rule", "rule"),
    ("second", "after 2nd pass [mm]"),
    ("paper_second", "paper"),
    ("improvement", "improvement (final)"),
    ("paper_improvement", "paper"),
    ("comment", "paper's comment"),
]

_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }
th { background: #f2f2f2; }
td { white-space: nowrap; }
td.l { white-space: normal; }
td.l, th.l { text-align: left; }
td.paper { color: #a33; }
figure { margin: 1.5em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.92em; color: #444; }
code, pre { background: #f6f6f6; padding: 0.1em 0.3em; }
.small { font-size: 0.85em; color: #555; }
"""


def _html_table(headers, rows, left=()):
    out = [
        "<table>",
        "<tr>" + "".join(f'<th class="{"l" if i in left else ""}">{h}</th>' for i, h in enumerate(headers)) + "</tr>",
    ]
    for r in rows:
        out.append("<tr>" + "".join(f'<td class="{c}">{html.escape(str(v))}</td>' for v, c in r) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def _page_head(study: Study, command: str) -> list[str]:
    """The page's head, its title and the study's settings, and the heading of Table I."""
    cfg = study.config
    e = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        "<title>umbmark: reproducing Borenstein &amp; Feng, section 5</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        "<h1>Reproducing the paper in simulation</h1>",
        "<p>Borenstein &amp; Feng, <i>Measurement and correction of systematic odometry errors in mobile "
        "robots</i>, section 5 and Table I, with the simulated LabMate of umbmark: "
        f"{cfg.geometry.wheelbase_m * 1e3:.0f} mm nominal wheelbase, "
        f"{cfg.side_m:g} &times; {cfg.side_m:g} m square, {cfg.motion.speed_m_s:g} m/s, stop and turn on the spot, "
        f"{cfg.n_runs} runs per direction, noise <code>{e(cfg.noise.name)}</code>, sampling period "
        f"{cfg.sample_period_s * 1e3:g} ms.</p>",
        f"<p>Re-run with: <code>{e(command)}</code> (umbmark {e(__version__)}). The same seeds give the same "
        "numbers.</p>",
        "<h2>Table I, default seed</h2>",
        f"<p>Seed {cfg.seed}. Our numbers beside the paper's (red). The 3&times;SEM rule: a second compensation "
        "pass is made when E<sub>max,syst</sub> after the first pass is at least 3 SEM of the direction that sets "
        "it (SEM = radial standard deviation / &radic;n). Experiments 3-5 share their uncalibrated runs and "
        "their correction factors, as in the paper.</p>",
    ]
    return parts


def _table_i(study: Study, dd: dict) -> list[str]:
    """Table I of the first seed beside the paper's, and the paper's spread."""
    parts = []
    rows = table_rows(study)
    parts.append(
        _html_table(
            [h for _, h in _COLUMNS],
            [
                [
                    (r[k], "paper" if k.startswith("paper") else ("l" if k in ("comment", "id") else ""))
                    for k, _ in _COLUMNS
                ]
                for r in rows
            ],
            left=(0, 13),
        )
    )
    parts.append(
        f"<p class=small>Paper: per-run spread &sigma; &asymp; {PAPER_SIGMA_MM:g} mm, SEM {PAPER_SEM_MM:g} mm. "
        f"Simulated: median radial standard deviation after calibration {dd['std_after_median_mm']:.1f} mm.</p>"
    )
    return parts


def _distribution(dd: dict) -> list[str]:
    """The distribution over all seeds: medians and percentiles, the second-pass share."""
    parts = []
    parts.append(f"<h2>Distribution over {dd['seeds']} seeds ({dd['seed_first']}..{dd['seed_last']})</h2>")
    dist_rows = [
        ("E_max,syst before [mm]", dd["emax_before_median_mm"], dd["emax_before_p10_mm"], dd["emax_before_p90_mm"]),
        (
            "E_max,syst after 1st pass [mm]",
            dd["emax_after_median_mm"],
            dd["emax_after_p10_mm"],
            dd["emax_after_p90_mm"],
        ),
        ("E_max,syst final [mm]", dd["emax_final_median_mm"], dd["emax_final_p10_mm"], dd["emax_final_p90_mm"]),
        (
            "improvement, 1st pass",
            dd["improvement_first_pass_median"],
            dd["improvement_first_pass_p10"],
            dd["improvement_first_pass_p90"],
        ),
        ("improvement, final", dd["improvement_median"], dd["improvement_p10"], dd["improvement_p90"]),
    ]
    parts.append(
        _html_table(
            ["", "median", "10th percentile", "90th percentile"],
            [[(n, "l"), (fmt(m), ""), (fmt(a), ""), (fmt(b), "")] for n, m, a, b in dist_rows],
            left=(0,),
        )
    )
    parts.append(
        f"<p>Second pass called for by the rule in {dd['second_pass_fraction'] * 100:.1f}% of the experiments; "
        f"final improvement at least 10-fold in {dd['fraction_improvement_at_least_10'] * 100:.1f}%. "
        "Paper: 10- to 22-fold, 12-35 mm after calibration.</p>"
    )
    return parts


def _second_passes(study: Study) -> list[str]:
    """The first experiments where the 3 x SEM rule called for a second pass."""
    parts = []
    ex = study.second_pass_examples
    if ex:
        parts.append("<h2>Second compensation passes</h2>")
        parts.append(
            f"<p>The first {len(ex)} experiments, in seed order, where the 3&times;SEM rule called for a second pass "
            "(the correction measured on the calibrated robot, composed with the first, then fresh runs). The paper's "
            "experiment 7: 423 mm, 66 mm after the first pass (3&times;SEM = 33.6 mm), 20 mm after the second.</p>"
        )
        parts.append(
            _html_table(
                [
                    "seed",
                    "exp.",
                    "E<sub>max,syst</sub> before [mm]",
                    "after 1st pass [mm]",
                    "3&times;SEM [mm]",
                    "after 2nd pass [mm]",
                    "improvement (final)",
                ],
                [
                    [
                        (str(x.seed), ""),
                        (str(x.id), ""),
                        (fmt(x.emax_before * 1e3, 0), ""),
                        (fmt(x.emax_after * 1e3), ""),
                        (fmt(None if x.first.result.sem_rule is None else x.first.result.sem_rule * 1e3), ""),
                        (fmt(x.emax_final * 1e3), ""),
                        (f"{x.improvement_final:.1f}-fold", ""),
                    ]
                    for x in ex
                ],
            )
        )
    return parts


def _figures(study: Study, pngs: dict) -> list[str]:
    """The figures, embedded as base64 PNG, with their titles and captions."""
    e = html.escape
    parts = []
    order = ["distribution", "scatter", "trajectories", "pitfall"]
    for name in order:
        if name not in pngs:
            continue
        title, text = FIGURES[name]
        b64 = base64.b64encode(pngs[name]).decode("ascii")
        parts.append(f"<h2>{e(title)}</h2>")
        if name == "pitfall" and study.pitfall is not None:
            pd = study.pitfall.to_dict()
            parts.append(
                f"<p>Robot: the Fig. 11 robot (true b {pd['robot_wheelbase_mm']:.2f} mm, E_d {pd['robot_Ed']:.5f}). "
                f"Tuned on cw runs only: b = {pd['tuned_wheelbase_mm']:.2f} mm; cw r<sub>cg</sub> "
                f"{pd['uni_directionally_tuned']['cw_r_cg_mm']:.0f} mm, ccw r<sub>cg</sub> "
                f"{pd['uni_directionally_tuned']['ccw_r_cg_mm']:.0f} mm (uncalibrated: "
                f"{pd['uncalibrated']['emax_syst_mm']:.0f} mm). UMBmark + the paper's correction: b = "
                f"{pd['bf_wheelbase_mm']:.2f} mm, E_max,syst {pd['bi_directional_bf']['emax_syst_mm']:.0f} mm.</p>"
            )
        parts.append(
            f'<figure><img src="data:image/png;base64,{b64}" alt="{e(title)}">'
            f"<figcaption>{e(text)} Files: {name}.png, {name}.svg.</figcaption></figure>"
        )
    return parts


def _models(study: Study) -> list[str]:
    """The models and assumptions of the simulation, and the end of the page."""
    cfg = study.config
    parts = []
    tm = study.to_dict()["tape_model"]
    parts += [
        "<h2>Models and assumptions</h2>",
        "<ul>",
        "<li>Experiment 1: the paper's Fig. 11 robot (E_d = 1.00084, b = 336.17 mm). Experiments 2, 3-5, 6: the "
        f"same robot on other days, E_d - 1 and E_b - 1 each multiplied by exp({cfg.variation:g} z), z ~ N(0, 1), "
        "drawn from the seed.</li>",
        f"<li>Masking tape: one loop adds 2 &times; {tm['layer_thickness_mm']:g} mm to the wheel's diameter "
        f"(wheels {tm['wheel_diameter_mm']:g} mm). Experiment 7: E_d = {tm['exp7']['Ed']:.5f}, noise-free "
        f"E_max,syst before {tm['exp7']['noise_free_emax_before_mm']:.0f} mm (paper 423); experiment 8: E_d = "
        f"{tm['exp8']['Ed']:.5f}, {tm['exp8']['noise_free_emax_before_mm']:.0f} mm (paper 232). The thickness is an "
        "effective value inferred from experiment 7's before figure, not a measured one.</li>",
        "<li>Noise: the <code>paper</code> preset's wheel slip, floor bumps and sonar measurement noise "
        "(2 mm, 0.4&deg;)"
        + (
            ", encoders not quantised so that every segment stops exactly on its target."
            if not cfg.noise.quantise
            else ", quantised encoders (the robot stops at the first sample past its target)."
        )
        + "</li>",
        "</ul>",
        "</body></html>",
    ]
    return parts


def render_html(study: Study, pngs: dict, command: str) -> str:
    """The report's page: the settings, Table I, the distribution, the second passes, the figures, the models.

    Parameters
    ----------
    study : Study
        The study.
    pngs : dict
        Figure name (see :data:`FIGURES`) -> its PNG bytes, embedded in the page.
    command : str
        The command that re-runs the study, shown on the page.

    Returns
    -------
    str
        One HTML document, ending with a newline.
    """
    dd = study.distribution.to_dict()
    parts = _page_head(study, command) + _table_i(study, dd) + _distribution(dd) + _second_passes(study)
    parts += _figures(study, pngs) + _models(study)
    return "\n".join(parts) + "\n"


def write_report(study: Study, out_dir, command: str = "umbmark reproduce", exaggerate: float = 1.0) -> Path:
    """Write the figures (PNG, SVG) and ``index.html`` into a folder, readable by all.

    Parameters
    ----------
    study : Study
        The study.
    out_dir : str or Path
        The folder (created if needed).
    command : str
        The command that re-runs the study, shown on the page.
    exaggerate : float
        Magnification of the deviation of the true paths in the trajectory figure.

    Returns
    -------
    Path
        The page, ``out_dir / "index.html"``.

    Raises
    ------
    InputError
        If ``out_dir`` exists and is not a folder, or ``exaggerate`` is not positive.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"cannot write the report: {out_dir} exists and is not a folder")
    made = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        figs = study_figures(study, exaggerate)
        saved = save_study_figures(figs, out_dir)
        pngs = {k: v["_png"] for k, v in saved.items()}
        page = out_dir / "index.html"
        atomic_write(page, render_html(study, pngs, command))
    except BaseException:
        if made and not any(out_dir.iterdir()):
            out_dir.rmdir()  # a report that could not be written leaves no empty folder
        raise
    for p in [page] + [f for v in saved.values() for k, f in v.items() if k != "_png"]:
        _readable(p)
    return page


def _readable(path):
    """Temporary files are created private (0600); a report is meant to be read (0644)."""
    try:
        os.chmod(path, 0o644)
    except OSError:  # pragma: no cover - e.g. a file system without permissions
        pass
