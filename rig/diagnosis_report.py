"""Presenting a diagnosis: text, JSON, rerun recording, static HTML report.

Rerun entities (SI; units in the names):

* ``diagnosis/runs/<run>/phi_rad/{measured,nominal,extended}``: one period of the relative
  angle, timeline ``t_s``.
* ``diagnosis/runs/<run>/departure_rad/{nominal,extended}``: simulated minus measured.
* ``diagnosis/loops/<run>/{measured,nominal,extended}``: the restoring-force loop, joint
  torque (N m) against relative angle (rad), as 2D line strips.
* ``diagnosis/harmonic_residuals/<run>/{nominal,extended}``: |Phi_n model - measured| (rad),
  n = 0..band, bar charts.
* ``diagnosis/causes``: bar chart of the causes' scores in ranked order;
  ``diagnosis/summary``: the text report (markdown).
"""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from .validate import DiagnosisReport

__all__ = ["report_json", "format_report", "log_diagnosis", "write_html"]


def _fmt(v: float) -> str:
    return "nan" if not math.isfinite(v) else f"{v:.6g}"


def _finite(obj):
    """JSON has no inf/NaN: non-finite numbers become null."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def report_json(report: DiagnosisReport, *, source: str = "", notes: Sequence[str] = (),
                input_sha256: str = "") -> dict:
    out = _report_json(report, source=source, notes=list(notes) + list(report.notes))
    if input_sha256:
        out = {"source": out.pop("source"), "input_sha256": input_sha256, **out}
    return _finite(out)


def _report_json(report: DiagnosisReport, *, source: str, notes: Sequence[str]) -> dict:
    d = report.diagnosis
    runs = report.runs
    ext = d.extended
    effects = list(d.effects)
    return {
        "source": source,
        "units": "SI: rad, rad/s, N m, s, kg m^2; names carry the unit",
        "form": d.form,
        "band_harmonics": report.band,
        "fit_runs": [r.run_id for r in runs if not r.held_out],
        "holdout_runs": [r.run_id for r in runs if r.held_out],
        "noise_std": d.noise_std,
        "notes": list(notes) + list(d.notes),
        "nominal": {"parameters": d.nominal.as_dict(),
                    "std_errors": dict(zip(d.nominal.names, map(float, d.nominal.std_errors))),
                    "chi2_per_dof": d.nominal.chi2 / d.nominal.dof},
        "causes": [c.as_json() for c in d.causes],
        "verdict": report.verdict.verdict,
        "verdict_reason": report.verdict.reason,
        "misfit_character": report.character.as_json() if report.verdict.verdict == "unexplained" else None,
        "extended": {"effect": effects[0] if effects else "none", "effects": list(report.adopted),
                     "tried": effects,
                     "dynamic_effects": list(d.effects_of_kind("dynamic")),
                     "measurement_effects": list(d.effects_of_kind("measurement")),
                     "parameters": ext.effect_parameters(),
                     "std_errors": {n: ext.std_error(n) for n in ext.effect_parameters()},
                     "magnitudes": {s.effect: {"name": s.magnitude[0], "value": ext.effect_parameters().get(
                         s.magnitude[0], s.magnitude[1]), "std_error": ext.std_error(s.magnitude[0])}
                         for s in d.steps},
                     "chi2_per_dof": ext.chi2 / ext.dof},
        "ambiguous": [a.as_json() for a in d.ambiguous],
        "validation_rms": {"nominal": report.validation_rms("nominal"),
                           "extended": report.validation_rms("extended"),
                           "noise_floor": report.noise_floor_rad, "unit": "rad",
                           "what": "RMS of simulated minus measured relative angle, period-averaged, over the "
                                   "harmonics the measurement resolves, on the held-out runs"},
        "gain": report.gain,
        "runs": [{"run": r.run_id, "omega_rad_s": r.omega_rad_s, "amplitude_Nm": r.amplitude_Nm,
                  "held_out": r.held_out, "rms_nominal_rad": r.rms("nominal"),
                  "rms_extended_rad": r.rms("extended"), "noise_floor_rad": r.noise_floor_rad}
                 for r in runs],
    }


def format_report(report: DiagnosisReport, *, source: str = "", notes: Sequence[str] = ()) -> str:
    d = report.diagnosis
    lines = []
    fit_ids = [r.run_id for r in report.runs if not r.held_out]
    held = [r.run_id for r in report.runs if r.held_out]
    v = report.verdict
    lines.append(f"VERDICT: {v.verdict.upper().replace('_', ' ')}: {v.reason}")
    if v.verdict == "unexplained":
        lines.append(f"  What the misfit looks like: {report.character.describe()}")
    lines.append("")
    lines.append(f"Diagnosis of {source or 'the runs'}: {len(report.runs)} runs, "
                 f"{'two-degree-of-freedom form (phi1, phi2)' if d.form == 'two_dof' else 'equivalent form (phi)'}, "
                 f"harmonics 0..{report.band}")
    lines.append(f"  fit on runs {', '.join(fit_ids)}; held out for validation: {', '.join(held)}")
    lines.append("  noise per sample (from period-to-period variation): "
                 + ", ".join(f"{k} {_fmt(v)}" for k, v in d.noise_std.items()))
    for n in list(notes) + list(d.notes) + list(report.notes):
        lines.append(f"  note: {n}")
    lines.append("")
    lines.append(f"Nominal model (paper eq. 11): chi2/dof = {d.nominal.chi2 / d.nominal.dof:.3g} "
                 f"(about 1 when only noise is left)")
    for n, v, s in zip(d.nominal.names, d.nominal.values, d.nominal.std_errors):
        lines.append(f"  {n:34s} {v:14.6g} +- {s:.2g}")
    lines.append("")
    lines.append("Causes ranked by evidence (score = drop in chi2 - n_params ln(n_rows); significant: "
                 "p < 1e-3 / n_causes):")
    lines.append(f"  {'rank':4s} {'effect':22s} {'score':>12s} {'d_chi2':>12s} {'q':>2s} {'p':>9s} {'sig':>4s}  "
                 f"magnitude; where the improvement is (mean/fund./even/odd>=3); dissipative share")
    for i, c in enumerate(d.causes, 1):
        sig = c.signature
        where = "/".join(f"{sig.get(k, 0.0):.0%}" for k in ("mean", "fundamental", "even", "odd>=3")) if sig else "-"
        if sig and sig.get("dissipative") is not None:
            where += f"; {sig['dissipative']:.2f}"
        mag = f"{c.magnitude[0]} = {_fmt(c.magnitude[1])} +- {_fmt(c.magnitude[2])}"
        lines.append(f"  {i:<4d} {c.effect:22s} {c.score:12.4g} {c.delta_chi2:12.4g} {c.n_params:2d} "
                     f"{c.p_value:9.2g} {'yes' if c.significant else 'no':>4s}  {mag}; {where}"
                     + (f"  [{c.note}]" if c.note else ""))
    lines.append("")
    if d.steps:
        joint, sensors = d.effects_of_kind("dynamic"), d.effects_of_kind("measurement")
        what = " + ".join(joint) or "no joint effect"
        if sensors:
            what += f"; in the sensors: {' + '.join(sensors)}"
        lines.append(f"Extended model: {what}; chi2/dof = {d.extended.chi2 / d.extended.dof:.3g}")
    else:
        lines.append("Extended model: none needed (no cause is significant; the nominal model explains the data "
                     "to the noise)")
    ext = d.extended
    for n, v in ext.effect_parameters().items():
        lines.append(f"  {n:34s} {v:14.6g} +- {_fmt(ext.std_error(n))}")
    for a in d.ambiguous:
        lines.append(f"  CANNOT TELL APART: {a.effects[0]} and {a.effects[1]} explain the same part of the data "
                     f"(neither is significant given the other). To separate them: {a.excitation}.")
    lines.append("")
    lines.append("Validation in the MuJoCo rig under each run's measured drive (RMS of the relative angle, rad, "
                 "over the harmonics the measurement resolves):")
    lines.append(f"  {'run':>6s} {'omega':>8s} {'M0':>8s} {'held out':>8s} {'nominal':>10s} {'extended':>10s} "
                 f"{'floor':>10s}")
    for r in report.runs:
        lines.append(f"  {r.run_id:>6s} {r.omega_rad_s:8.4g} {r.amplitude_Nm:8.4g} {'yes' if r.held_out else '':>8s} "
                     f"{r.rms('nominal'):10.3g} {r.rms('extended'):10.3g} {r.noise_floor_rad:10.3g}")
    lines.append(f"  held-out runs: nominal {report.validation_rms('nominal'):.3g} rad, extended "
                 f"{report.validation_rms('extended'):.3g} rad, noise floor {report.noise_floor_rad:.3g} rad; "
                 f"gain {report.gain:.3g}")
    return "\n".join(lines)


def _label(r) -> str:
    return f"run{r.run_id}".replace(".", "p").replace("/", "_").replace(" ", "_")


def diagnosis_blueprint(report: DiagnosisReport):
    """The diagnosis recording's layout (rerun blueprint): a first tab that answers the question
    (the verdict and report text, the causes by name with the adopted ones marked, their scores),
    then one tab per run titled with omega and M0: measured, nominal and extended relative angle
    overlaid, simulated minus measured, the restoring-force loops (normalised: rad and N m on one
    2D view would be a line) and the harmonic residuals on a log scale."""
    import rerun.blueprint as rrb

    first = rrb.Horizontal(
        rrb.TextDocumentView(origin="diagnosis/summary", name="Verdict and report"),
        rrb.Vertical(rrb.TextDocumentView(origin="diagnosis/causes_table", name="Causes (adopted marked)"),
                     rrb.BarChartView(origin="diagnosis/causes", name="Cause evidence score, in table order")),
        column_shares=[3, 2], name="Verdict")
    tabs = [first]
    whole = rrb.VisibleTimeRange("t_s", start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    axis = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                 end=rrb.TimeRangeBoundary.infinite()))
    for r in report.runs:
        lab = _label(r)
        held = ", held out" if r.held_out else ""
        tabs.append(rrb.Grid(
            rrb.TimeSeriesView(origin=f"diagnosis/runs/{lab}/phi_rad",
                               name="relative angle [rad]: measured, nominal, extended", time_ranges=whole,
                               axis_x=axis),
            rrb.TimeSeriesView(origin=f"diagnosis/runs/{lab}/departure_rad", name="simulated - measured [rad]",
                               time_ranges=whole, axis_x=axis),
            rrb.Spatial2DView(origin=f"diagnosis/loops/{lab}",
                              name="restoring-force loop (phi / max|phi|, torque / max|torque|)"),
            rrb.BarChartView(origin=f"diagnosis/harmonic_residuals/{lab}/extended",
                             name="|harmonic residual| of the extended model [rad]"),
            grid_columns=2, name=f"run {r.run_id}: {r.omega_rad_s:g} rad/s, {r.amplitude_Nm:.4g} N m{held}"))
    return rrb.Blueprint(rrb.Tabs(*tabs), rrb.TimePanel(timeline="t_s", state="collapsed"), collapse_panels=True)


def log_diagnosis(rec, report: DiagnosisReport, text: str) -> None:
    import rerun as rr

    rec.send_blueprint(diagnosis_blueprint(report))
    colors = {"measured": (40, 40, 40), "nominal": (214, 39, 40), "extended": (31, 119, 180)}
    for r in report.runs:
        lab = _label(r)
        t = rr.TimeColumn("t_s", duration=r.time_s)
        for w, phi in (("measured", r.phi_measured_rad), ("nominal", r.phi_nominal_rad),
                       ("extended", r.phi_extended_rad)):
            rec.log(f"diagnosis/runs/{lab}/phi_rad/{w}", rr.SeriesLines(colors=[colors[w]], names=[w]), static=True)
            rec.send_columns(f"diagnosis/runs/{lab}/phi_rad/{w}", indexes=[t], columns=rr.Scalars.columns(scalars=phi))
        taus = (("measured", r.joint_torque_measured_Nm), ("nominal", r.joint_torque_nominal_Nm),
                ("extended", r.joint_torque_extended_Nm))
        phi_scale = max(float(np.max(np.abs(r.phi_resolved_rad))), 1e-300)
        tau_scale = max(max(float(np.max(np.abs(tau))) for _, tau in taus if np.all(np.isfinite(tau))), 1e-300)
        for w, tau in taus:
            # Normalised (and y up): a loop in rad against N m on one equal-aspect view is a line.
            pts = np.column_stack([r.phi_resolved_rad / phi_scale, -tau / tau_scale])
            rec.log(f"diagnosis/loops/{lab}/{w}", rr.LineStrips2D([np.vstack([pts, pts[:1]])], colors=[colors[w]]),
                    static=True)
        for w, phi in (("nominal", r.phi_nominal_rad), ("extended", r.phi_extended_rad)):
            rec.log(f"diagnosis/harmonic_residuals/{lab}/{w}", rr.BarChart(r.harmonic_residuals(w, report.band)),
                    static=True)
            rec.log(f"diagnosis/runs/{lab}/departure_rad/{w}", rr.SeriesLines(colors=[colors[w]], names=[w]),
                    static=True)
            rec.send_columns(f"diagnosis/runs/{lab}/departure_rad/{w}", indexes=[t],
                             columns=rr.Scalars.columns(scalars=phi - r.phi_measured_rad))
    causes = [c for c in report.diagnosis.causes if math.isfinite(c.score)]
    adopted = set(report.adopted)
    rec.log("diagnosis/causes", rr.BarChart(np.array([c.score for c in causes]),
                                            abscissa=np.arange(1, len(causes) + 1)), static=True)
    table = ["| # | cause | score | significant | adopted | magnitude |", "|---|---|---|---|---|---|"]
    for i, c in enumerate(causes, 1):
        table.append(f"| {i} | {c.effect} | {c.score:.4g} | {'yes' if c.significant else 'no'} | "
                     f"{'**ADOPTED**' if c.effect in adopted else ''} | {c.magnitude[0]} = {_fmt(c.magnitude[1])} +- "
                     f"{_fmt(c.magnitude[2])} |")
    table.append(f"\nVerdict: **{report.verdict.verdict}**: {report.verdict.reason}")
    rec.log("diagnosis/causes_table", rr.TextDocument("\n".join(table), media_type=rr.MediaType.MARKDOWN),
            static=True)
    rec.log("diagnosis/summary", rr.TextDocument("```\n" + text + "\n```", media_type=rr.MediaType.MARKDOWN),
            static=True)


def _png(fig) -> str:
    buf = io.BytesIO()
    # The figures are laid out by tight_layout already: bbox_inches="tight" would lay them out
    # (draw them) a second time.
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figures(report: DiagnosisReport) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = report.runs
    n = len(runs)
    cols = min(3, n)
    rows = math.ceil(n / cols)
    out = []
    style = {"measured": dict(color="k", lw=2.2, alpha=0.5), "nominal": dict(color="tab:red", lw=1.2, ls="--"),
             "extended": dict(color="tab:blue", lw=1.2)}

    def grid(height, draw, caption):
        """One panel per run, drawn by ``draw(ax, run)``; appended to ``out`` as a PNG."""
        fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, height * rows), squeeze=False)
        for ax, r in zip(axes.flat, runs):
            draw(ax, r)
        for ax in list(axes.flat)[n:]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=8)
        fig.tight_layout()
        out.append((caption, _png(fig)))
        plt.close(fig)

    def held(r):
        return " (held out)" if r.held_out else ""

    def time_series(ax, r):
        for w, phi in (("measured", r.phi_measured_rad), ("nominal", r.phi_nominal_rad),
                       ("extended", r.phi_extended_rad)):
            ax.plot(r.time_s, phi, label=w, **style[w])
        ax.set_title(f"run {r.run_id}: {r.omega_rad_s:g} rad/s, {r.amplitude_Nm:.4g} N m{held(r)}", fontsize=9)
        ax.set(xlabel="t [s]", ylabel="phi [rad]")

    def departure(ax, r):
        ax.axhspan(-r.noise_floor_rad, r.noise_floor_rad, color="0.85", label="noise floor")
        for w, phi in (("nominal", r.phi_nominal_rad), ("extended", r.phi_extended_rad)):
            ax.plot(r.time_s, phi - r.phi_measured_rad, label=w, **style[w])
        ax.set_title(f"run {r.run_id}{held(r)}", fontsize=9)
        ax.set(xlabel="t [s]", ylabel="simulated - measured [rad]")

    def loops(ax, r):
        x = np.append(r.phi_resolved_rad, r.phi_resolved_rad[0])
        for w, tau in (("measured", r.joint_torque_measured_Nm), ("nominal", r.joint_torque_nominal_Nm),
                       ("extended", r.joint_torque_extended_Nm)):
            ax.plot(x, np.append(tau, tau[0]), label=w, **style[w])
        ax.set_title(f"run {r.run_id}{held(r)}", fontsize=9)
        ax.set(xlabel="phi [rad]", ylabel="joint torque [N m]")

    h = np.arange(report.band + 1)

    def residuals(ax, r):
        ax.bar(h - 0.2, r.harmonic_residuals("nominal", report.band), width=0.4, color="tab:red", label="nominal")
        ax.bar(h + 0.2, r.harmonic_residuals("extended", report.band), width=0.4, color="tab:blue", label="extended")
        ax.set_yscale("log")
        ax.set_title(f"run {r.run_id}{held(r)}", fontsize=9)
        ax.set(xlabel="harmonic n", ylabel="|residual| [rad]")

    grid(2.8, time_series, "Relative angle over one period: measured (period average) vs simulated in the rig")
    grid(2.8, departure, "Where the simulation departs from the measurement: simulated minus measured relative "
                         "angle (band-limited), with the noise floor of the comparison")
    grid(3.2, loops, "Restoring-force loops: joint torque against relative angle (measured from the equation of "
                     "motion with the extended model's inertia; models from their laws along the measured motion)")
    grid(2.8, residuals, "Harmonic residuals per run: |Phi_n simulated - Phi_n measured|")

    causes = [c for c in report.diagnosis.causes if math.isfinite(c.score)]
    fig, ax = plt.subplots(figsize=(7, 0.45 * len(causes) + 1))
    ax.barh([c.effect for c in causes][::-1], [c.score for c in causes][::-1],
            color=["tab:green" if c.significant else "tab:gray" for c in causes][::-1])
    ax.set_xscale("symlog")
    ax.set_xlabel("evidence score (green: significant)")
    fig.tight_layout()
    out.append(("Causes ranked by evidence", _png(fig)))
    plt.close(fig)
    return out


def write_html(path: Path, report: DiagnosisReport, text: str, *, title: str = "jointrig diagnosis",
               input_sha256: str = "") -> Path:
    """A self-contained HTML report (the verdict as its headline, provenance, the text summary and
    embedded PNG figures), written atomically."""
    import datetime

    from jointrig import __version__

    v = report.verdict
    colour = {"no_misfit": "#2e7d32", "explained": "#1565c0", "unexplained": "#c62828"}[v.verdict]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    provenance = f"jointrig {__version__}, {stamp}" + (f", input SHA-256 {input_sha256}" if input_sha256 else "")
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
             "<style>body{font-family:sans-serif;max-width:1300px;margin:auto;padding:0 12px} pre{background:#f6f6f6;"
             "padding:8px;overflow-x:auto;white-space:pre} img{max-width:100%} .verdict{border-left:6px solid "
             f"{colour};padding:6px 12px;background:#fafafa;font-size:1.1em}} .prov{{color:#666;font-size:0.85em;"
             "overflow-wrap:anywhere}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>",
             f"<p class='verdict'><b>{html.escape(v.verdict.replace('_', ' ').upper())}</b>: {html.escape(v.reason)}</p>",
             f"<p class='prov'>{html.escape(provenance)}</p>",
             "<h2>Summary</h2>", f"<pre>{html.escape(text)}</pre>"]
    for caption, png in _figures(report):
        parts.append(f"<h2>{html.escape(caption)}</h2><img alt='{html.escape(caption)}' "
                     f"src='data:image/png;base64,{png}'>")
    parts.append("</body></html>")
    from .sweep import write_atomic

    path = Path(path)
    write_atomic(path, lambda tmp: tmp.write_text("\n".join(parts), encoding="utf-8"))
    return path
