"""The pieces of a report page shared by every diagnosis (pure: strings out): the page's top
with the verdict, tables, embedded SVG figures, the joint card's section and the unexplained
misfit's restoring-force surface."""

from __future__ import annotations

import base64
import html
from typing import Sequence

import numpy as np

from .formatting import sig

__all__ = ["page_top", "row", "table", "svg_figure_html", "card_section", "surface_figure"]


def surface_figure(srf, smp, words=None) -> str:
    """Three panels: the surface ``srf`` where the data support it, under the residual samples
    ``smp`` along the runs' loops (the classic restoring-force plot); the samples against the
    angle with the stiffness section, and against the rate with the damping section. ``words``:
    the place's quantities (:class:`present.misfit_words.Words`; a joint's by default)."""
    from .misfit_words import JOINT_WORDS

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


def row(cells, cls: str = "") -> str:
    """A table row; a cell is text, or ``(text, "num")`` for a right-aligned number."""
    out = []
    for c in cells:
        text, kind = (c if isinstance(c, tuple) else (c, ""))
        out.append(f"<td class='{kind}'>{html.escape(str(text))}</td>" if kind else f"<td>{html.escape(str(text))}</td>")
    return f"<tr class='{cls}'>" + "".join(out) + "</tr>" if cls else "<tr>" + "".join(out) + "</tr>"


def table(head: Sequence[str], rows: Sequence[str]) -> str:
    thead = ("<thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr></thead>") if head else ""
    return "<div class='wrap'><table>" + thead + "<tbody>" + "".join(rows) + "</tbody></table></div>"


def card_section(card, png_bytes: bytes) -> list[str]:
    """The joint card (studies/joint_card.py): runs beside the model at the same amplitude and
    frequency, the slopes, and the card's figure (``png_bytes``, :func:`present.card.card_png`)."""
    from .card import RUNS_INERTIAS, card_warning, masing_text, mode_text, model_name, point_cells, slope_text as slope

    rows = []
    for p, m in zip(card.runs.points, card.model_at_runs.points):
        for src, q, cls in (("runs", p, ""), ("model", m, "")):
            rows.append(row([f"{p.run} ({src})", (sig(q.amplitude_rad), "num"), (sig(q.omega_rad_s, 4), "num"),
                              *[(c, "num") for c in point_cells(q)]], cls))

    png = base64.b64encode(png_bytes).decode("ascii")
    warning = [f"<p class='warning'><b>Warning:</b> {html.escape(card_warning(card))}</p>"] if card.unadopted else []
    a_unit, k_unit = card.units
    place = f" of {card.place}" if card.place else ""
    return [f"<h2>Joint card{html.escape(place)} ({html.escape(model_name(card))})</h2>"] + warning + [
            f"<p class='note'>The {html.escape(mode_text(card))} (inertia Je = {sig(card.model.inertia_kgm2, 4)} "
            f"{'kg' if a_unit == 'm' else 'kg m²'}): each run beside the model at the same amplitude and drive "
            f"frequency (the runs' rows measured with {html.escape(RUNS_INERTIAS)} inertias); damping ratio = "
            "E / (2 pi k A²), half the loss factor.</p>",
            table(["run", f"A [{a_unit}]", "omega [rad/s]", f"k_sec [{k_unit}]", "omega_n [rad/s]", "damping ratio",
                    "E per cycle [J]"], rows),
            f"<p>Dissipation slope d lnE / d lnA: runs {html.escape(slope(card.runs))}; model at the runs "
            f"{html.escape(slope(card.model_at_runs))}; backbone {html.escape(slope(card.model))} (viscous 2, dry "
            f"friction 1, micro-slip 3 + chi).</p>",
            f"<p>{html.escape(masing_text(card.masing))}</p>",
            f"<figure><figcaption>Joint card against the amplitude</figcaption><img alt='joint card' "
            f"src='data:image/png;base64,{png}'></figure>"]


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

    from jointrig.version import __version__

    from .notes import verdict_text

    colour = {"no_misfit": "#2e7d32", "explained": "#1565c0", "unexplained": "#c62828"}[verdict.verdict]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    provenance = f"jointrig {__version__}, {stamp}" + (f"; input SHA-256 {input_sha256}" if input_sha256 else "")
    return [f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'><title>{html.escape(title)}</title>"
            f"<style>{_CSS}</style></head><body>",
            f"<h1>{html.escape(title)}</h1>", f"<p class='prov'>{html.escape(provenance)}</p>",
            f"<div class='verdict' style='--c:{colour}'><p><b>{html.escape(verdict.verdict.replace('_', ' ').upper())}"
            f"</b>: {html.escape(words)}</p><p class='why'>{html.escape(verdict_text(verdict))}</p></div>"]
