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
import math
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .diagnosis_json import DiagnosisJson, FitJson, RunJson, ValidationJson
from .formatting import quantity_of, sig, sig_or, unit_of, with_se
from .text import ValidationRow, ambiguity_lines, causes_lines, head_lines, notes_lines, parameter_lines, validation_lines
from .summary import NO_GAIN, adopted_causes, next_steps, parameter_rows, plain_verdict, written_rows
from jointrig.identify.verdict import CHI2_PER_DOF_OK
from jointrig.studies.validate import DIVERGES, INERTIAS_NOT_POSITIVE, NEVER_SETTLES, DiagnosisReport

__all__ = ["report_json", "format_report", "log_diagnosis", "write_html", "write_outputs"]

# Units of the measured channels whose noise is reported (angles are in rad).
_CHANNEL_UNIT = {"torque": "N m"}


def report_json(report: DiagnosisReport, *, source: str = "", notes: Sequence[str] = (),
                input_sha256: str = "", model: Optional[str] = None) -> dict:
    """The two-flywheel diagnosis as the one diagnosis document (:mod:`present.diagnosis_json`);
    ``model``: the user's model file (``--model``), if one was given."""
    d = report.diagnosis
    runs = report.runs
    unexplained = report.verdict.verdict == "unexplained"
    per_run = tuple(RunJson(r.run_id, r.held_out, r.omega_rad_s, r.amplitude_Nm, r.rms("nominal"), r.rms("extended"),
                            r.noise_floor_rad, r.failures) for r in runs)
    validation = ValidationJson(
        report.validation_kind, report.generalisation, report.validation_statement,
        "RMS of simulated minus measured relative angle, period-averaged, over the harmonics the measurement "
        "resolves, on the held-out data", "rad", report.validation_rms("nominal"), report.validation_rms("extended"),
        report.noise_floor_rad, report.gain, per_run,
        "; ".join(f"{which} model, run {r.run_id}: {r.failure(which)}" for r in runs
                  for which in ("nominal", "extended") if r.failure(which)))
    return DiagnosisJson(
        source=source, input_sha256=input_sha256, units="SI: rad, rad/s, N m, s, kg m^2; names carry the unit",
        kind="hinge", n_bodies=2, form=d.form, model=model, verdict=report.verdict, band_harmonics=report.band,
        fit_runs=tuple(r.run_id for r in runs if not r.held_out), held_out_runs=tuple(r.run_id for r in runs if r.held_out),
        noise_std_per_sample=dict(d.noise_std), nominal=FitJson.of(d.nominal), causes=tuple(d.causes),
        steps=tuple(d.steps), adopted=tuple(report.adopted), extended=FitJson.of(d.extended),
        ambiguities=tuple(d.ambiguous), as_written={w.name: w.as_json() for w in written_rows(report)},
        validation=validation, notes=tuple(notes) + tuple(report.notes) + tuple(d.notes),
        plausibility=tuple(d.plausibility),
        misfit_character=report.character.as_json() if unexplained else None,
        misfit_surface=report.surface.as_json() if unexplained else None,
        next_measurements=tuple(report.next_measurements) if unexplained else ()).as_json()


def format_report(report: DiagnosisReport, *, source: str = "", notes: Sequence[str] = ()) -> str:
    """The two-flywheel diagnosis as text, in the layout of every bench (:mod:`present.text`)."""
    d = report.diagnosis
    fit_ids = [r.run_id for r in report.runs if not r.held_out]
    held = [r.run_id for r in report.runs if r.held_out]
    v = report.verdict
    misfit = ([f"What the misfit looks like: {report.character.describe()}",
               f"Its restoring-force surface: {report.surface.describe()}"] if v.verdict == "unexplained" else [])
    lines = head_lines(v, plain_verdict(report), next_steps(report), written=written_rows(report), misfit=misfit)
    lines.append("")
    lines.append(f"Diagnosis of {source or 'the runs'}: {len(report.runs)} runs, "
                 f"{'two-degree-of-freedom form (phi1, phi2)' if d.form == 'two_dof' else 'equivalent form (phi)'}, "
                 f"harmonics 1..{report.band}")
    lines.append(f"  fit on runs {', '.join(fit_ids)}; held out for validation: {', '.join(held)}")
    lines.append("  noise per sample (from period-to-period variation): "
                 + ", ".join(f"{k} {sig(v, 2)} {_CHANNEL_UNIT.get(k, 'rad')}" for k, v in d.noise_std.items()))
    all_notes = list(notes) + list(d.notes) + list(report.notes)
    if all_notes:
        lines.append(f"  {len(all_notes)} note(s) on the data: at the end")
    lines.append("")
    lines.append(f"Nominal model (paper eq. 11): chi2/dof = {d.nominal.chi2 / d.nominal.dof:.3g} "
                 f"(about 0.4-1 when only noise is left, with the model-fidelity floor)")
    lines += parameter_lines({n: (x, d.nominal.std_error(n)) for n, x in d.nominal.as_dict().items()})
    lines.append("")
    lines += causes_lines(d.causes)
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
    lines += parameter_lines({n: (x, ext.std_error(n)) for n, x in ext.effect_parameters().items()})
    lines += ambiguity_lines(d.ambiguous)
    lines.append("")
    rows = [ValidationRow(r.run_id, r.omega_rad_s, r.amplitude_Nm, r.held_out, _rms_cell(r, "nominal"),
                          _rms_cell(r, "extended"), sig(r.noise_floor_rad)) for r in report.runs]
    failures = [f"the {which} model has no steady state in run(s) {', '.join(report.unsimulated(which))}: rejected "
                f"for that reason (see the notes)" for which in ("nominal", "extended") if report.unsimulated(which)]
    lines += validation_lines(
        rows, measure="RMS of the relative angle, rad, over the harmonics the measurement resolves", drive="M0",
        summary=f"nominal {_held_out_rms(report, 'nominal')}, extended {_held_out_rms(report, 'extended')}, noise "
                f"floor {report.noise_floor_rad:.3g} rad; gain {sig_or(report.gain, NO_GAIN)}",
        statement=("generalisation" if report.validation_kind == "held_out_runs" else "validation",
                   report.validation_statement), failures=failures)
    lines += notes_lines(all_notes)
    return "\n".join(lines)


def _rms_cell(r, which: str) -> str:
    """A run's validation RMS (rad), or why it has none ("diverges", "never settles")."""
    why = r.failure(which)
    return sig_or(r.rms(which), {DIVERGES: "diverges", NEVER_SETTLES: "no steady",
                                 INERTIAS_NOT_POSITIVE: "J <= 0"}.get(why, "not computed"))


def _held_out_rms(report, which: str) -> str:
    v = report.validation_rms(which)
    return f"{v:.3g} rad" if math.isfinite(v) else "none (no steady state in a held-out run)"


def _label(r) -> str:
    return f"run{r.run_id}".replace(".", "p").replace("/", "_").replace(" ", "_")


def _log_card(rec, card) -> None:
    """The joint card over the timeline ``amplitude_urad`` (the relative amplitude in urad):
    ``diagnosis/card/<quantity>/{model_backbone, runs, model_at_runs}``."""
    import rerun as rr

    series = (("model_backbone", card.model.points, (31, 119, 180)), ("runs", card.runs.points, (40, 40, 40)),
              ("model_at_runs", card.model_at_runs.points, (214, 39, 40)))
    for key in ("natural_frequency_rad_s", "damping_ratio", "dissipation_J_per_cycle", "secant_stiffness_Nm_per_rad"):
        for name, points, colour in series:
            pts = sorted(points, key=lambda q: q.amplitude_rad)
            idx = rr.TimeColumn("amplitude_urad", sequence=[int(round(q.amplitude_rad * 1e6)) for q in pts])
            path = f"diagnosis/card/{key}/{name}"
            if name == "model_backbone":
                rec.log(path, rr.SeriesLines(colors=[colour], names=[name]), static=True)
            else:
                rec.log(path, rr.SeriesPoints(colors=[colour], names=[name], marker_sizes=[4.0]), static=True)
            rec.send_columns(path, indexes=[idx], columns=rr.Scalars.columns(scalars=[getattr(q, key) for q in pts]))


def diagnosis_blueprint(report: DiagnosisReport, with_card: bool = False):
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
    if report.verdict.verdict == "unexplained":
        from .recording import misfit_tab

        tabs.insert(1, misfit_tab())
    if with_card:
        whole_a = rrb.VisibleTimeRange("amplitude_urad", start=rrb.TimeRangeBoundary.infinite(),
                                       end=rrb.TimeRangeBoundary.infinite())
        tabs.insert(1, rrb.Grid(*[
            rrb.TimeSeriesView(origin=f"diagnosis/card/{key}", name=f"{label} against A [urad] (timeline amplitude_urad)",
                               time_ranges=whole_a, axis_x=axis)
            for key, label in (("natural_frequency_rad_s", "natural frequency [rad/s]"),
                               ("damping_ratio", "damping ratio [-]"),
                               ("dissipation_J_per_cycle", "dissipation per cycle [J]"),
                               ("secant_stiffness_Nm_per_rad", "secant stiffness [N m/rad]"))],
            grid_columns=2, name="Joint card"))
    return rrb.Blueprint(rrb.Tabs(*tabs), rrb.TimePanel(timeline="t_s", state="collapsed"), collapse_panels=True)


def log_diagnosis(rec, report: DiagnosisReport, text: str, *, card=None) -> None:
    import rerun as rr

    rec.send_blueprint(diagnosis_blueprint(report, card is not None))
    if card is not None:
        _log_card(rec, card)
    if report.verdict.verdict == "unexplained":
        from .recording import log_misfit, misfit_text

        log_misfit(rec, report.surface, report.samples,
                   misfit_text(report.character.describe(), report.surface.describe(), report.next_measurements))
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
                     f"{'**ADOPTED**' if c.effect in adopted else ''} | {quantity_of(c.magnitude[0])} = "
                     f"{with_se(c.magnitude[1], c.magnitude[2])} {unit_of(c.magnitude[0])} |")
    table.append(f"\nVerdict: **{report.verdict.verdict}**: {report.verdict.reason}")
    rec.log("diagnosis/causes_table", rr.TextDocument("\n".join(table), media_type=rr.MediaType.MARKDOWN),
            static=True)
    rec.log("diagnosis/summary", rr.TextDocument("```\n" + text + "\n```", media_type=rr.MediaType.MARKDOWN),
            static=True)


def figures(report: DiagnosisReport) -> list[tuple[str, str]]:
    """``(caption, SVG document)`` of every figure of the report (:mod:`present.svg`): a panel per
    run (titled by its omega and M0, held-out runs marked) for the relative angle, its departure
    from the measurement, the restoring-force loops and the harmonic residuals; the causes ranked
    by evidence; for an unexplained misfit its restoring-force surface first."""
    from . import svg

    runs = report.runs
    cols = min(3, len(runs))
    style = {"measured": dict(color=svg.COLORS["black"], width=2.2, opacity=0.5),
             "nominal": dict(color=svg.COLORS["red"], width=1.2, dash="5 3"),
             "extended": dict(color=svg.COLORS["blue"], width=1.2)}
    out = []

    def title(r):
        return f"run {r.run_id}: {r.omega_rad_s:.4g} rad/s, {r.amplitude_Nm:.4g} N m" + (
            " (held out)" if r.held_out else "")

    def grid(caption, height, panel_of):
        panels = [panel_of(r) for r in runs]
        panels[0].legend = True
        out.append((caption, svg.figure(panels, cols=cols, panel_width=400, panel_height=height, title=caption)))

    def time_series(r):
        p = svg.Panel(title(r), "t [s]", "phi [rad]")
        for w, phi in (("measured", r.phi_measured_rad), ("nominal", r.phi_nominal_rad),
                       ("extended", r.phi_extended_rad)):
            p.line(r.time_s, phi, label=w, **style[w])
        return p

    def departure(r):
        p = svg.Panel(title(r), "t [s]", "simulated - measured [rad]")
        p.band(-r.noise_floor_rad, r.noise_floor_rad, color=svg.COLORS["band"], label="noise floor")
        for w, phi in (("nominal", r.phi_nominal_rad), ("extended", r.phi_extended_rad)):
            p.line(r.time_s, phi - r.phi_measured_rad, label=w, **style[w])
        return p

    def loops(r):
        p = svg.Panel(title(r), "phi [rad]", "joint torque [N m]")
        x = np.append(r.phi_resolved_rad, r.phi_resolved_rad[0])
        for w, tau in (("measured", r.joint_torque_measured_Nm), ("nominal", r.joint_torque_nominal_Nm),
                       ("extended", r.joint_torque_extended_Nm)):
            p.line(x, np.append(tau, tau[0]), label=w, **style[w])
        return p

    h = np.arange(report.band + 1)

    def residuals(r):
        nom, ext = r.harmonic_residuals("nominal", report.band), r.harmonic_residuals("extended", report.band)
        pos = np.concatenate([nom, ext])
        pos = pos[pos > 0]
        floor = float(pos.min()) / 3 if pos.size else 1e-12
        p = svg.Panel(title(r), "harmonic n", "|residual| [rad]", yscale="log", ylim=(floor, None),
                      xlim=(-0.75, report.band + 0.75))
        width = 0.4 * 300 / (report.band + 1.5)  # px: 0.4 of a harmonic's slot on a ~300 px wide frame
        for dx, vals, colour, label in ((-0.2, nom, "red", "nominal"), (0.2, ext, "blue", "extended")):
            p.vlines(h + dx, floor, np.maximum(vals, floor), color=svg.COLORS[colour], width=width, label=label)
        return p

    if report.verdict.verdict == "unexplained":
        out.append(("The unexplained misfit as a restoring-force surface: the residual joint torque (measured "
                    "minus the final model) at every sample of the runs' loops over the relative angle and rate, "
                    "on its fitted surface (shaded where the data support it); the samples against the angle "
                    "and the rate, with the surface's stiffness section S(phi, 0) and damping section S(0, phi')",
                    surface_figure(report.surface, report.samples)))
    grid("Relative angle over one period: measured (period average) vs simulated in the rig", 252, time_series)
    grid("Where the simulation departs from the measurement: simulated minus measured relative angle "
         "(band-limited), with the noise floor of the comparison", 252, departure)
    grid("Restoring-force loops: joint torque against relative angle (measured from the equation of motion with "
         "the extended model's inertia; models from their laws along the measured motion)", 288, loops)
    grid("Harmonic residuals per run: |Phi_n simulated - Phi_n measured|", 252, residuals)

    causes = [c for c in report.diagnosis.causes if math.isfinite(c.score)][::-1]
    adopted = set(report.adopted)
    # A cause rejected on physical grounds (its note says why) has no evidence to show: no bar.
    chart = svg.Panel(xlabel="evidence score (blue: adopted; black edge: significant; rejected causes: no bar)",
                      xscale="symlog",
                      ycategories=tuple(c.effect + (" (adopted)" if c.effect in adopted else " (rejected)" if c.note
                                                    else "") for c in causes),
                      ybold=tuple(c.effect in adopted for c in causes))
    chart.barh([0.0 if c.note else c.score for c in causes],
               colors=[svg.COLORS["blue" if c.effect in adopted else "gray"] for c in causes],
               edges=["#000" if c.significant else None for c in causes])
    out.append(("Causes ranked by evidence", svg.figure([chart], cols=1, panel_width=640,
                                                          panel_height=30 * len(causes) + 70,
                                                          title="Causes ranked by evidence")))
    return out


def surface_figure(srf, smp, words=None) -> str:
    """Three panels: the surface ``srf`` where the data support it, under the residual samples
    ``smp`` along the runs' loops (the classic restoring-force plot); the samples against the
    angle with the stiffness section, and against the rate with the damping section. ``words``:
    the place's quantities (:class:`identify.surface.Words`; a joint's by default)."""
    from jointrig.identify.surface import JOINT_WORDS

    from . import svg

    w = words or JOINT_WORDS
    a, r = f"{w.angle} - centre [{w.angle_unit}]", f"{w.angle}' [{w.angle_unit}/s]"
    q = f"residual {w.torque} [{w.torque_unit}]"
    x, v, res = (np.concatenate(a) for a in (smp.phi_rad, smp.rate_rad_s, smp.residual_Nm))
    # colour limits robust to one run far off (the 98th percentile of |residual|)
    top = max(float(np.percentile(np.abs(res), 98)), 1e-300)
    shade = svg.colormap_rdbu(np.ravel(srf.torque_Nm), -top, top)
    n_phi, n_rate = srf.torque_Nm.shape
    cells = [[shade[i * n_rate + j] if srf.supported[i, j] else None for j in range(n_rate)] for i in range(n_phi)]
    surface = svg.Panel(f"residual over ({w.angle}, {w.angle}'): samples on the surface", a, r,
                        colorbar=(-top, top, q))
    surface.grid(srf.phi_knots_rad, srf.rate_knots_rad_s, cells, opacity=0.45)
    surface.points(x, v, color=svg.colormap_rdbu(res, -top, top), radius=1.3)
    panels = [surface]
    for data, (sx, sy), lab, name in ((x, srf.stiffness_section, a,
                                       f"against the {w.motion}; stiffness section S({w.angle}, 0)"),
                                      (v, srf.damping_section, r,
                                       f"against the rate; damping section S(0, {w.angle}')")):
        p = svg.Panel(name, lab, q)
        p.hline(0.0, color=svg.COLORS["light"])
        p.points(data, res, color=svg.COLORS["mid"], radius=1.1, label="samples")
        p.line(sx, sy, color=svg.COLORS["purple"], marker=True, label="surface section (supported knots)")
        panels.append(p)
    panels[1].legend = True
    return svg.figure(panels, cols=3, panel_width=420, panel_height=350, widths=[1.45, 1, 1],
                      title="the unexplained misfit as a restoring-force surface")


_CSS = """
body{font-family:system-ui,sans-serif;max-width:1240px;margin:auto;padding:0 16px;color:#222;line-height:1.4}
h1{margin-bottom:4px} h2{margin-top:28px;border-bottom:1px solid #ddd;padding-bottom:2px}
.verdict{border-left:6px solid var(--c);padding:4px 14px;background:#fafafa;font-size:1.15em}
.verdict .why{font-size:0.75em;color:#444} details.section{margin-top:20px} details.section>summary{font-size:1.2em;font-weight:600;cursor:pointer;padding:4px 0}
.prov{color:#555;font-size:0.85em;overflow-wrap:anywhere}
table{border-collapse:collapse;margin:8px 0;font-size:0.92em;max-width:100%}
.wrap{overflow-x:auto;max-width:100%}
th,td{border-bottom:1px solid #e3e3e3;padding:3px 10px;text-align:left;vertical-align:top}
th{background:#f3f3f3} td.unit{white-space:nowrap} td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.adopted td{background:#e8f1fb;font-weight:600} tr.heldout td:first-child::after{content:" (held out)";
color:#666;font-weight:normal}
.tag{display:inline-block;padding:0 6px;border-radius:3px;background:#1565c0;color:#fff;font-size:0.8em}
.note{color:#555;font-size:0.9em} .warning{background:#fff3cd;border-left:4px solid #c80;padding:6px 10px} img{max-width:100%;height:auto} figure{margin:12px 0}
figcaption{color:#444;font-size:0.92em;margin-bottom:4px}
details pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:0.8em}
"""


def _row(cells, cls: str = "") -> str:
    """A table row; a cell is text, or ``(text, "num")`` for a right-aligned number."""
    out = []
    for c in cells:
        text, kind = (c if isinstance(c, tuple) else (c, ""))
        out.append(f"<td class='{kind}'>{html.escape(str(text))}</td>" if kind else f"<td>{html.escape(str(text))}</td>")
    return f"<tr class='{cls}'>" + "".join(out) + "</tr>" if cls else "<tr>" + "".join(out) + "</tr>"


def _table(head: Sequence[str], rows: Sequence[str]) -> str:
    thead = ("<thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr></thead>") if head else ""
    return "<div class='wrap'><table>" + thead + "<tbody>" + "".join(rows) + "</tbody></table></div>"


def _parameter_rows(fit, values: dict) -> list[str]:
    return [_row([quantity_of(n), unit_of(n), (with_se(v, fit.std_error(n)), "num")]) for n, v in values.items()]




def _summary_section(report: DiagnosisReport) -> list[str]:
    """The first screen below the verdict: the adopted causes with their size, the model's
    parameters as given beside the data's, and what to do next."""
    out = []
    causes = adopted_causes(report)
    if causes:
        out.append("<h2>What your model misses</h2><ul class='causes'>" + "".join(
            f"<li><b>{html.escape(a.name)}</b>: {html.escape(a.what)}; {html.escape(a.quantity)} "
            f"<b>{html.escape(a.value)}</b></li>" for a in causes) + "</ul>")
    written = written_rows(report)
    if written:
        out.append("<h2>Your model as written</h2><p class='note'>Each parameter of your model file beside what the "
                   "data say (" + ("the model with the adopted causes" if report.adopted else "your model's structure "
                   "fitted to the runs") + ", ± one standard error); \"differs\" when they are more than two "
                   "standard errors apart.</p>")
        out.append(_table(["parameter", "unit", "as written", "the data say", "differs?"],
                          [_row([w.quantity, (w.unit, "unit"), (f"{w.written:.6g}", "num"),
                                 (with_se(w.data, w.std_error), "num"),
                                 f"yes, {w.change}" if w.differs else "no"], "adopted" if w.differs else "")
                           for w in written]))
    rows = parameter_rows(report)
    extended = bool(report.adopted)
    head = (["parameter", "unit", "your model, fitted", "with the adopted causes", "differs?"] if extended
            else ["parameter", "unit", "your model, fitted"])
    body = [_row([r.quantity, (r.unit, "unit"), (r.as_given, "num")]
                 + ([(r.with_causes, "num"), "yes" if r.differs else "no"] if extended else []),
                 "adopted" if extended and r.differs else "") for r in rows]
    out.append("<h2>The joint's parameters</h2><p class='note'>Your model's structure (" + (
               "as your model file has it" if report.written else "inertias, c phi' + k phi + gamma phi^3")
               + ") fitted to the runs"
               + (", beside the same with the adopted causes; \"differs\" when the two are more than twice their "
                  "combined standard error apart" if extended else "")
               + ". Values ± one standard error.</p>")
    out.append(_table(head, body))
    steps = next_steps(report)
    if steps:
        out.append("<h2>What to do next</h2><ul>" + "".join(f"<li>{html.escape(t)}</li>" for t in steps) + "</ul>")
    return out


def _html_sections(report: DiagnosisReport, source: str, notes: Sequence[str]) -> list[str]:
    """The report below its first screen: what an unexplained misfit looks like and the
    validation per run; numbers to the precision of their standard errors, units beside them."""
    out = []
    if report.verdict.verdict == "unexplained":
        out.append("<h2>What the unexplained misfit looks like</h2>"
                   f"<p>{html.escape(report.character.describe())}.</p>"
                   f"<p>Its restoring-force surface (the residual joint torque over angle and rate, Masri and "
                   f"Caughey's method on bilinear hat functions; figure below): "
                   f"{html.escape(report.surface.describe())}.</p>")

    out.append("<h2>Validation in the MuJoCo rig</h2><p class='note'>Each run simulated under its measured "
               "drive; the error is the RMS of simulated minus measured relative angle over the harmonics the "
               "measurement resolves. The noise floor is what a perfect model would score, given the noise.</p>")
    rows = [_row([r.run_id, (sig(r.omega_rad_s, 4), "num"), (sig(r.amplitude_Nm, 4), "num"),
                  (_rms_cell(r, "nominal"), "num"), (_rms_cell(r, "extended"), "num"), (sig(r.noise_floor_rad), "num")],
                 "heldout" if r.held_out else "") for r in report.runs]
    rows.append(_row(["held-out runs", "", "", (sig_or(report.validation_rms("nominal"), "none"), "num"),
                      (sig_or(report.validation_rms("extended"), "none"), "num"), (sig(report.noise_floor_rad), "num")],
                     "adopted"))
    out.append(_table(["run", "omega [rad/s]", "M0 [N m]", "nominal [rad]", "extended [rad]", "noise floor [rad]"],
                      rows))
    for which in ("nominal", "extended"):
        if report.unsimulated(which):
            out.append(f"<p>The {which} model reaches no periodic steady state in run(s) "
                       f"{html.escape(', '.join(report.unsimulated(which)))} under the measured drive: it is rejected "
                       f"for that reason, and its error there has no number.</p>")
    out.append(f"<p>Held-out gain (the nominal model's error over the extended model's: how much better the "
               f"extension predicts): "
               f"<b>{sig_or(report.gain, NO_GAIN)}</b>; "
               f"{html.escape(report.validation_statement)}.</p>")
    return out


def _collapsed_sections(report: DiagnosisReport, source: str, notes: Sequence[str]) -> list[str]:
    """The evidence (nominal model, causes ranked, extended model) and the data with its notes,
    each folded under a summary line: below the answer, for who wants to check it."""
    d = report.diagnosis
    adopted = set(report.adopted)
    fit_ids = [r.run_id for r in report.runs if not r.held_out]
    held = [r.run_id for r in report.runs if r.held_out]
    out = []
    ev = ["<details class='section'><summary>The evidence: the nominal model, every cause tried, the extended "
          "model</summary>"]
    ev.append(f"<h3>Nominal model (paper eq. 11)</h3><p>chi2/dof = {sig(d.nominal.chi2 / d.nominal.dof)}: how far "
              f"the model misses the runs, in units of their noise (about 0.4-1 when only noise is left; the verdict "
              f"asks at most {CHI2_PER_DOF_OK:g})</p>")
    ev.append(_table(["parameter", "unit", "value ± standard error"], _parameter_rows(d.nominal, d.nominal.as_dict())))
    ev.append("<h3>Causes ranked by evidence</h3><p class='note'>Each cause is added to the nominal model in turn. "
              "Δchi2 is how much it lowers the misfit; the score discounts that for the parameters it adds "
              "(Δchi2 minus parameters x ln(rows), the Bayesian information criterion); p is the chance of a drop "
              "this large if the cause were absent (p &lt; 1e-300: far beyond chance), and a cause counts as significant when p &lt; 0.001 / number of "
              "causes. A significant cause can still be rejected (a negative friction, a slip below what the "
              "angles resolve: the note under it says why), and a significant sensor cause is adopted only when it "
              "explains the data as well as the best cause in the joint. Adopted causes are highlighted.</p>")
    rows = []
    head = ["#", "cause", "score", "Δchi2", "params", "p", "significant", "magnitude", "value ± s.e.", "unit"]
    for i, c in enumerate(d.causes, 1):
        name, value, se = c.magnitude
        cls = "adopted" if c.effect in adopted else ""
        rows.append(_row([(str(i), "num"), c.effect + ("  [adopted]" if c.effect in adopted else ""),
                          (sig(c.score, 4), "num"), (sig(c.delta_chi2, 4), "num"), (str(c.n_params), "num"),
                          ("< 1e-300" if c.p_value == 0 else sig(c.p_value, 2), "num"),
                          ("no (rejected)" if c.note and c.p_value < 1e-3 else "yes" if c.significant else "no"),
                          quantity_of(name), (with_se(value, se), "num"), (unit_of(name), "unit")], cls))
        if c.note:
            rows.append(f"<tr class='{cls}'><td></td><td class='note' colspan='{len(head) - 1}'>"
                        f"{html.escape(c.note)}</td></tr>")
    ev.append(_table(head, rows))
    for a in d.ambiguous:
        ev.append(f"<p><b>Cannot tell apart:</b> {html.escape(a.effects[0])} and {html.escape(a.effects[1])} "
                  f"explain the same part of the data. To separate them: {html.escape(a.excitation)}.</p>")
    ext = d.extended
    if d.steps:
        what = " + ".join(d.effects)
        status = "adopted" if adopted else "tried; not adopted, see the verdict"
        ev.append(f"<h3>Extended model: {html.escape(what)} ({status})</h3>"
                  f"<p>chi2/dof = {sig(ext.chi2 / ext.dof)}</p>")
        ev.append(_table(["parameter", "unit", "value ± standard error"], _parameter_rows(ext, ext.effect_parameters())))
    else:
        ev.append("<h3>Extended model</h3><p>None: no cause is significant.</p>")
    ev.append("</details>")
    out += ev

    all_notes = list(notes) + list(d.notes) + list(report.notes)
    data = [f"<details class='section'><summary>The data: {len(report.runs)} runs, the noise, "
            f"{len(all_notes)} note(s) on how they were read</summary>", _table([], [
                _row(["input", source or "(runs given in Python)"]),
                _row(["runs", f"{len(report.runs)}: fitted on {', '.join(fit_ids)}; held out for validation: "
                              f"{', '.join(held) or 'none'}"]),
                _row(["model form", "two-degree-of-freedom (phi1, phi2)" if d.form == "two_dof"
                      else "equivalent single degree of freedom (relative angle phi)"]),
                _row(["harmonics balanced", f"1..{report.band}"])])]
    data.append("<h3>Noise per raw sample (from the period-to-period variation)</h3>")
    data.append(_table(["channel", "unit", "standard deviation"],
                       [_row([ch, _CHANNEL_UNIT.get(ch, "rad"), (sig(v, 2), "num")]) for ch, v in d.noise_std.items()]))
    if all_notes:
        data.append("<h3>Notes on the data</h3><ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in all_notes)
                    + "</ul>")
    data.append("</details>")
    out += data
    return out


def _card_section(card, png_bytes: bytes) -> list[str]:
    """The joint card (studies/joint_card.py): runs beside the model at the same amplitude and
    frequency, the slopes, and the card's figure (``png_bytes``, :func:`present.card.card_png`)."""
    from .card import masing_text, point_cells, slope_text as slope

    rows = []
    for p, m in zip(card.runs.points, card.model_at_runs.points):
        for src, q, cls in (("runs", p, ""), ("model", m, "")):
            rows.append(_row([f"{p.run} ({src})", (sig(q.amplitude_rad), "num"), (sig(q.omega_rad_s, 4), "num"),
                              *[(c, "num") for c in point_cells(q)]], cls))

    png = base64.b64encode(png_bytes).decode("ascii")
    warning = [f"<p class='warning'><b>Warning:</b> {html.escape(card.warning)}</p>"] if card.warning else []
    a_unit, k_unit = card.units
    place = f" of {card.place}" if card.place else ""
    return [f"<h2>Joint card{html.escape(place)} ({html.escape(card.model_name)})</h2>"] + warning + [
            f"<p class='note'>The {html.escape(card.mode)} (inertia Je = {sig(card.model.inertia_kgm2, 4)} "
            f"{'kg' if a_unit == 'm' else 'kg m²'}): each run beside the model at the same amplitude and drive "
            f"frequency (the runs' rows measured with {html.escape(card.runs_inertias)} inertias); damping ratio = "
            "E / (2 pi k A²), half the loss factor.</p>",
            _table(["run", f"A [{a_unit}]", "omega [rad/s]", f"k_sec [{k_unit}]", "omega_n [rad/s]", "damping ratio",
                    "E per cycle [J]"], rows),
            f"<p>Dissipation slope d lnE / d lnA: runs {html.escape(slope(card.runs))}; model at the runs "
            f"{html.escape(slope(card.model_at_runs))}; backbone {html.escape(slope(card.model))} (viscous 2, dry "
            f"friction 1, micro-slip 3 + chi).</p>",
            f"<p>{html.escape(masing_text(card.masing))}</p>",
            f"<figure><figcaption>Joint card against the amplitude</figcaption><img alt='joint card' "
            f"src='data:image/png;base64,{png}'></figure>"]


def write_outputs(report: DiagnosisReport, text: str, *, rrd: Optional[Path] = None, html_path: Optional[Path] = None,
                  title: str = "jointrig diagnosis", input_sha256: str = "", source: str = "",
                  notes: Sequence[str] = (), card=None, card_png_path: Optional[Path] = None,
                  card_title: str = "") -> None:
    """The rerun recording (``rrd``), the HTML report (``html_path``, :func:`write_html`) and the
    joint card's figure as a PNG (``card_png_path``, of ``card``), each written atomically: the
    recording and the page are independent pieces of work, done in forked processes
    (:func:`jointrig.parallel.fork_map`) when both are asked for. The card's figure is drawn once
    (matplotlib: half a second), for the page and the PNG alike, titled ``card_title`` (default
    "joint card: " and the card's model). The same files either way."""
    from jointrig.parallel import fork_map

    if card_png_path is not None and card is None:
        raise ValueError("write_outputs: card_png_path needs the card")
    jobs = []
    if rrd is not None:
        jobs.append(lambda: _write_recording(rrd, report, text, card))
    if html_path is not None or card_png_path is not None:
        jobs.append(lambda: _write_page_and_card(html_path, report, text, title=title, input_sha256=input_sha256,
                                                 source=source, notes=notes, card=card, card_png_path=card_png_path,
                                                 card_title=card_title))
    for _ in fork_map(lambda job: job(), jobs):
        pass


def _write_page_and_card(html_path: Optional[Path], report: DiagnosisReport, text: str, *, card, card_png_path,
                         card_title: str, **page) -> None:
    """The page (if ``html_path``) and the card's PNG (if ``card_png_path``), the card's figure drawn once."""
    from jointrig.files import write_atomic

    png = None
    if card is not None:
        from .card import card_png

        png = card_png(card, title=card_title or f"joint card: {card.model_name}")
    if card_png_path is not None:
        write_atomic(Path(card_png_path), lambda tmp: tmp.write_bytes(png))
    if html_path is not None:
        _write_page(html_path, report, text, figures(report), card=card, card_png=png, **page)


def _write_recording(rrd: Path, report: DiagnosisReport, text: str, card) -> None:
    from .recording import open_recording

    with open_recording(rrd) as rec:
        log_diagnosis(rec, report, text, card=card)


def write_html(path: Path, report: DiagnosisReport, text: str, *, title: str = "jointrig diagnosis",
               input_sha256: str = "", source: str = "", notes: Sequence[str] = (), card=None) -> Path:
    """A self-contained HTML report, written atomically: the verdict as its headline, provenance
    (tool version, date, input SHA-256), tables with units and numbers to the precision of their
    standard errors (adopted causes marked), embedded SVG figures with every run panel titled by
    its omega and M0, and the console text folded at the end."""
    write_outputs(report, text, html_path=path, title=title, input_sha256=input_sha256, source=source, notes=notes,
                  card=card)
    return Path(path)


def svg_figure_html(caption: str, image: str) -> str:
    """An SVG figure embedded in a page (self-contained: a data URI) under its caption."""
    data = base64.b64encode(image.encode("utf-8")).decode("ascii")
    return (f"<figure><figcaption>{html.escape(caption)}</figcaption><img alt='{html.escape(caption)}' "
            f"src='data:image/svg+xml;base64,{data}'></figure>")


def page_top(title: str, verdict, words: str, input_sha256: str = "") -> list[str]:
    """The start of a report page, the same for every diagnosis: the head with its style, the
    title, the provenance (version, time, the input's SHA-256) and the verdict box (the verdict
    in words, its reason in figures under it)."""
    import datetime

    from jointrig import __version__

    colour = {"no_misfit": "#2e7d32", "explained": "#1565c0", "unexplained": "#c62828"}[verdict.verdict]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    provenance = f"jointrig {__version__}, {stamp}" + (f"; input SHA-256 {input_sha256}" if input_sha256 else "")
    return [f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'><title>{html.escape(title)}</title>"
            f"<style>{_CSS}</style></head><body>",
            f"<h1>{html.escape(title)}</h1>", f"<p class='prov'>{html.escape(provenance)}</p>",
            f"<div class='verdict' style='--c:{colour}'><p><b>{html.escape(verdict.verdict.replace('_', ' ').upper())}"
            f"</b>: {html.escape(words)}</p><p class='why'>{html.escape(verdict.reason)}</p></div>"]


def _write_page(path: Path, report: DiagnosisReport, text: str, drawn: Sequence[tuple[str, str]], *, title: str,
                input_sha256: str, source: str, notes: Sequence[str], card, card_png: Optional[bytes]) -> None:
    """The HTML page of :func:`write_html` with its figures ``drawn`` (``(caption, SVG document)``)."""
    parts = page_top(title, report.verdict, plain_verdict(report), input_sha256)
    parts += _summary_section(report)
    parts += _html_sections(report, source, notes)
    if card is not None:
        parts += _card_section(card, card_png)
    parts += [svg_figure_html(caption, image) for caption, image in drawn]
    parts += _collapsed_sections(report, source, notes)
    parts.append(f"<details><summary>The same report as console text</summary><pre>{html.escape(text)}</pre></details>")
    parts.append("</body></html>")
    from jointrig.files import write_atomic

    path = Path(path)
    write_atomic(path, lambda tmp: tmp.write_text("\n".join(parts), encoding="utf-8"))
