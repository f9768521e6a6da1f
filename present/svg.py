"""Figures as SVG text: the HTML report's plots, drawn without a plotting library.

The diagnosis report's figures are small multiples of line plots (a panel per run), bars and a
scatter; matplotlib drew them in 1.3 s of CPU and imported and warmed up in 0.4 s more, 40% of
a diagnosis's CPU (measured on the worn joint: ``jointrig diagnose runs.csv --json OUT --rrd OUT``
3.4 s of CPU, with ``--report OUT`` too 5.3-5.8 s). Here a panel is a few SVG elements written
from numpy arrays (all five figures in 0.02 s), vector graphics that stay sharp when a reader
zooms into a report.

What is drawn and how:

- :class:`Panel` collects series in data coordinates (lines, horizontal bands, vertical bars,
  points, a shaded grid, horizontal bars); :func:`figure` lays panels out on a grid with margins
  fixed in pixels (room for the tick labels and the axis labels) and returns one ``<svg>``
  document, to embed as an ``<img>``.
- Axes: limits from the data with 5% margins (log axes in decades), ticks at 1, 2, 2.5 or 5
  times a power of ten (at most ``max_ticks`` intervals), a common power of ten factored out
  above the axis when the ticks are below 1e-3 or at least 1e5, log axes at the decades
  (2 and 5 in between when the view spans less than two), a symmetric-log axis (``symlog``:
  ``sign(x) log10(1 + |x|)``) for values of both signs over decades.
- The legend of a panel goes to the corner its data leave freest.

Pure functions and a collector: arrays in, text out; nothing here reads or writes files.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

__all__ = ["Panel", "figure", "nice_ticks", "log_ticks", "tick_labels", "colormap_rdbu", "COLORS"]

#: The colours of the report (matplotlib's "tab" palette and greys, so the report reads as before).
COLORS = {"blue": "#1f77b4", "red": "#d62728", "purple": "#9467bd", "gray": "#7f7f7f", "black": "#000000",
          "band": "#d9d9d9", "light": "#b3b3b3", "mid": "#8c8c8c"}

FONT = "DejaVu Sans, Verdana, Arial, sans-serif"
TICK_PX = 11.0   # tick-label font size
LABEL_PX = 12.0  # axis-label font size
TITLE_PX = 11.5
CHAR_EM = 0.6    # a generous mean advance of a character, in em (layout only: the browser sets the text)
_SUPER = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
MINUS = "\u2212"


def nice_ticks(lo: float, hi: float, max_ticks: int = 4) -> np.ndarray:
    """Ticks at multiples of the smallest step 1, 2, 2.5, 5 or 10 times a power of ten that
    cuts ``[lo, hi]`` into at most ``max_ticks`` intervals; only the ticks inside ``[lo, hi]``."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        raise ValueError(f"nice_ticks: expected finite lo < hi, got {lo!r}, {hi!r}")
    raw = (hi - lo) / max(int(max_ticks), 1)
    power = 10.0 ** math.floor(math.log10(raw))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        step = m * power
        if step >= raw * (1 - 1e-12):
            break
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    ticks = np.arange(first, last + 1) * step
    ticks[np.abs(ticks) < step * 1e-9] = 0.0
    return ticks


def log_ticks(lo: float, hi: float) -> np.ndarray:
    """Decades inside ``[lo, hi]`` (both > 0); with 2 and 5 times them too when fewer than two
    decades fall inside."""
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ValueError(f"log_ticks: expected 0 < lo < hi, got {lo!r}, {hi!r}")
    a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    decades = np.array([10.0 ** k for k in range(a, b + 1)])
    inside = decades[(decades >= lo * (1 - 1e-12)) & (decades <= hi * (1 + 1e-12))]
    if inside.size >= 2:
        return inside
    fine = np.array([m * d for d in decades for m in (1.0, 2.0, 5.0)])
    return fine[(fine >= lo * (1 - 1e-12)) & (fine <= hi * (1 + 1e-12))]


def _power_label(v: float) -> str:
    """``10⁻⁵``, ``2×10⁻⁵``: a log tick."""
    if v == 0:
        return "0"
    sign = MINUS if v < 0 else ""
    k = math.floor(math.log10(abs(v)) + 1e-9)
    m = abs(v) / 10.0 ** k
    mant = "" if abs(m - 1) < 1e-9 else f"{m:.3g}×"
    if k == 0 and not mant:
        return f"{sign}1"
    if k == 1 and not mant:
        return f"{sign}10"
    return f"{sign}{mant}10{str(k).translate(_SUPER)}"


def tick_labels(ticks: np.ndarray) -> tuple[list[str], int]:
    """Labels of linear ticks with as many decimals as their step needs, and the power of ten
    factored out of them (0 when none: the ticks' largest magnitude is from 1e-3 to below 1e5)."""
    ticks = np.asarray(ticks, dtype=float)
    if ticks.size == 0:
        return [], 0
    top = float(np.max(np.abs(ticks)))
    power = 0
    if top > 0:
        oom = math.floor(math.log10(top))
        if oom < -3 or oom >= 5:
            power = oom
    scaled = ticks / 10.0 ** power
    if scaled.size >= 2:
        step = float(np.min(np.diff(scaled)))
    else:
        step = abs(float(scaled[0])) or 1.0
    decimals = 0
    while decimals < 10 and np.max(np.abs(np.round(scaled, decimals) - scaled)) > 1e-6 * step:
        decimals += 1
    labels = [f"{0.0 if abs(s) < 1e-12 * max(step, 1e-300) else s:.{decimals}f}".replace("-", MINUS) for s in scaled]
    return labels, power


def colormap_rdbu(values: np.ndarray, lo: float, hi: float) -> list[str]:
    """Hex colours of ``values`` on ColorBrewer's diverging RdBu, reversed (blue below the middle
    of ``[lo, hi]``, red above: matplotlib's ``RdBu_r``), clipped at the ends."""
    anchors = np.array([[0x05, 0x30, 0x61], [0x21, 0x66, 0xac], [0x43, 0x93, 0xc3], [0x92, 0xc5, 0xde],
                        [0xd1, 0xe5, 0xf0], [0xf7, 0xf7, 0xf7], [0xfd, 0xdb, 0xc7], [0xf4, 0xa5, 0x82],
                        [0xd6, 0x60, 0x4d], [0xb2, 0x18, 0x2b], [0x67, 0x00, 0x1f]], dtype=float)
    t = np.clip((np.asarray(values, dtype=float) - lo) / (hi - lo), 0.0, 1.0) * (len(anchors) - 1)
    k = np.minimum(t.astype(int), len(anchors) - 2)
    f = (t - k)[:, None]
    rgb = np.rint(anchors[k] * (1 - f) + anchors[k + 1] * f).astype(int)
    return [f"#{r:02x}{g:02x}{b:02x}" for r, g, b in rgb.tolist()]


def _symlog(x):
    x = np.asarray(x, dtype=float)
    return np.sign(x) * np.log10(1.0 + np.abs(x))


@dataclass
class _Series:
    kind: str
    data: tuple
    style: dict
    label: Optional[str] = None


@dataclass
class Panel:
    """One plot's content in data coordinates; :func:`figure` draws it.

    ``xscale``/``yscale``: ``"linear"``, ``"log"`` or ``"symlog"``; ``xlim``/``ylim`` override the
    limits from the data (either end may be None); ``legend``: draw one in the freest corner."""
    title: str = ""
    xlabel: str = ""
    ylabel: str = ""
    xscale: str = "linear"
    yscale: str = "linear"
    xlim: tuple = (None, None)
    ylim: tuple = (None, None)
    legend: bool = False
    max_ticks: int = 4
    series: list = field(default_factory=list)
    ycategories: tuple = ()       # category labels of a horizontal bar chart, bottom to top
    ybold: tuple = ()             # which of them are bold
    colorbar: Optional[tuple] = None  # (lo, hi, label) of an RdBu_r colour scale beside the panel

    def line(self, x, y, *, color: str, width: float = 1.2, dash: Optional[str] = None, opacity: float = 1.0,
             label: Optional[str] = None, marker: bool = False) -> "Panel":
        """A polyline (broken where x or y is not finite); ``marker``: points only, as dots."""
        self.series.append(_Series("line", (np.asarray(x, float), np.asarray(y, float)),
                                   dict(color=color, width=width, dash=dash, opacity=opacity, marker=marker), label))
        return self

    def band(self, y0: float, y1: float, *, color: str, label: Optional[str] = None) -> "Panel":
        """A horizontal band across the panel."""
        self.series.append(_Series("band", (float(y0), float(y1)), dict(color=color), label))
        return self

    def hline(self, y: float, *, color: str, width: float = 0.8) -> "Panel":
        self.series.append(_Series("hline", (float(y),), dict(color=color, width=width)))
        return self

    def vlines(self, x, y0, y1, *, color: str, width: float, label: Optional[str] = None) -> "Panel":
        """Vertical bars from ``y0`` to ``y1`` at each ``x`` (``width`` in px)."""
        x = np.asarray(x, float)
        self.series.append(_Series("vlines", (x, np.broadcast_to(np.asarray(y0, float), x.shape),
                                              np.broadcast_to(np.asarray(y1, float), x.shape)),
                                   dict(color=color, width=width), label))
        return self

    def points(self, x, y, *, color, radius: float = 1.5, label: Optional[str] = None) -> "Panel":
        """Dots; ``color`` one colour or one per point."""
        self.series.append(_Series("points", (np.asarray(x, float), np.asarray(y, float)),
                                   dict(color=color, radius=radius), label))
        return self

    def grid(self, xk, yk, colors, *, opacity: float = 1.0) -> "Panel":
        """A shaded grid: the cell around knot (i, j) of ``xk`` x ``yk`` filled with
        ``colors[i][j]`` (None: not drawn); cells reach halfway to the neighbouring knots."""
        self.series.append(_Series("grid", (np.asarray(xk, float), np.asarray(yk, float), colors),
                                   dict(opacity=opacity)))
        return self

    def barh(self, values, *, colors: Sequence[str], edges: Sequence[Optional[str]]) -> "Panel":
        """Horizontal bars, one per category (``ycategories``), from 0 to each value."""
        self.series.append(_Series("barh", (np.asarray(values, float),), dict(colors=list(colors),
                                                                              edges=list(edges))))
        return self


class _Scale:
    """Data -> pixel along one axis."""

    def __init__(self, kind: str, lo: float, hi: float, p0: float, p1: float):
        self.kind, self.lo, self.hi, self.p0, self.p1 = kind, lo, hi, p0, p1
        self._a, self._b = self._t(np.array(lo)), self._t(np.array(hi))

    def _t(self, v):
        v = np.asarray(v, dtype=float)
        if self.kind == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.log10(v)
        if self.kind == "symlog":
            return _symlog(v)
        return v

    def __call__(self, v):
        return self.p0 + (self._t(v) - self._a) / (self._b - self._a) * (self.p1 - self.p0)

    def ticks(self, max_ticks: int) -> tuple[np.ndarray, list[str], int]:
        if self.kind == "log":
            t = log_ticks(self.lo, self.hi)
            return t, [_power_label(v) for v in t], 0
        if self.kind == "symlog":
            top = max(abs(self.lo), abs(self.hi))
            mags = [0.0] + [10.0 ** k for k in range(0, int(math.floor(math.log10(max(top, 1.0)))) + 1)]
            t = np.array(sorted({s * m for m in mags for s in (-1, 1)}))
            t = t[(t >= self.lo) & (t <= self.hi)]
            return t, [_power_label(v) for v in t], 0
        t = nice_ticks(self.lo, self.hi, max_ticks)
        labels, power = tick_labels(t)
        return t, labels, power


def _limits(kind: str, values: np.ndarray, fixed: tuple, margin: float = 0.05) -> tuple[float, float]:
    """Axis limits: the data's range widened by ``margin`` of it on each side (in log10 on a log
    axis, in the symlog transform on a symlog one), ends fixed by the caller kept."""
    v = values[np.isfinite(values)]
    if kind == "log":
        v = v[v > 0]
    if v.size == 0:
        lo, hi = (1.0, 10.0) if kind == "log" else (0.0, 1.0)
    else:
        lo, hi = float(v.min()), float(v.max())
    if kind == "log":
        a, b = math.log10(lo), math.log10(hi)
        if b - a < 1e-12:
            a, b = a - 0.5, b + 0.5
        d = margin * (b - a)
        lo, hi = 10.0 ** (a - d), 10.0 ** (b + d)
    elif kind == "symlog":
        a, b = float(_symlog(lo)), float(_symlog(hi))
        if b - a < 1e-12:
            a, b = a - 0.5, b + 0.5
        d = margin * (b - a)
        lo, hi = float(np.sign(a - d) * (10.0 ** abs(a - d) - 1)), float(np.sign(b + d) * (10.0 ** abs(b + d) - 1))
    else:
        if hi - lo <= 1e-300 or hi - lo <= 1e-12 * max(abs(lo), abs(hi)):
            pad = abs(lo) * 0.05 or 1.0
            lo, hi = lo - pad, hi + pad
        d = margin * (hi - lo)
        lo, hi = lo - d, hi + d
    lo = fixed[0] if fixed[0] is not None else lo
    hi = fixed[1] if fixed[1] is not None else hi
    if not hi > lo:  # a fixed end beyond the data's other end: a decade (or a unit) of room
        hi = lo * 10.0 if kind == "log" else lo + (abs(lo) or 1.0)
    return lo, hi


def _data_x(s: _Series) -> list:
    if s.kind in ("line", "points", "vlines", "grid"):
        return [s.data[0]]
    if s.kind == "barh":
        return [np.append(s.data[0], 0.0)]
    return []


def _data_y(s: _Series) -> list:
    if s.kind in ("line", "points"):
        return [s.data[1]]
    if s.kind == "vlines":
        return [s.data[1], s.data[2]]
    if s.kind in ("band", "hline"):
        return [np.array(s.data)]
    if s.kind == "grid":
        return [s.data[1]]
    return []


def _cell_edges(knots: np.ndarray) -> np.ndarray:
    """Edges of the cells around knots (at least 2): halfway between neighbours, half a spacing
    beyond the end knots."""
    k = np.asarray(knots, dtype=float)
    return np.concatenate([[k[0] - (k[1] - k[0]) / 2], (k[1:] + k[:-1]) / 2, [k[-1] + (k[-1] - k[-2]) / 2]])


def _path(px: np.ndarray, py: np.ndarray) -> str:
    """An SVG path through the points, broken where a coordinate is not finite."""
    ok = np.isfinite(px) & np.isfinite(py)
    out = []
    pen_up = True
    for a, b, good in zip(px.tolist(), py.tolist(), ok.tolist()):
        if not good:
            pen_up = True
            continue
        out.append(f"{'M' if pen_up else 'L'}{a:.1f} {b:.1f}")
        pen_up = False
    return "".join(out)


def _text(x: float, y: float, s: str, *, size: float, anchor: str = "middle", weight: str = "normal",
          rotate: Optional[float] = None, baseline: str = "auto", color: str = "#222") -> str:
    rot = f" transform='rotate({rotate:.0f} {x:.1f} {y:.1f})'" if rotate is not None else ""
    bold = " font-weight='bold'" if weight == "bold" else ""
    base = f" dominant-baseline='{baseline}'" if baseline != "auto" else ""
    return (f"<text x='{x:.1f}' y='{y:.1f}' font-size='{size:g}' text-anchor='{anchor}'{bold}{base}{rot} "
            f"fill='{color}'>{html.escape(s)}</text>")


def _width(s: str, size: float) -> float:
    return len(s) * CHAR_EM * size


def _legend_svg(panel: Panel, box: tuple, sx: _Scale, sy: _Scale) -> str:
    entries = [s for s in panel.series if s.label]
    if not entries:
        return ""
    x0, y0, x1, y1 = box
    line_h, sample_w, pad = 15.0, 22.0, 5.0
    w = pad * 3 + sample_w + max(_width(s.label, TICK_PX) for s in entries)
    h = pad * 2 + line_h * len(entries)
    # the corner the data leave freest (fewest drawn points under the box), upper right first
    pts_x, pts_y = [], []
    for s in panel.series:
        if s.kind in ("line", "points"):
            pts_x.append(sx(s.data[0]))
            pts_y.append(sy(s.data[1]))
        elif s.kind == "vlines":
            for yy in (s.data[1], s.data[2]):
                pts_x.append(sx(s.data[0]))
                pts_y.append(sy(yy))
    px = np.concatenate(pts_x) if pts_x else np.zeros(0)
    py = np.concatenate(pts_y) if pts_y else np.zeros(0)
    m = 4.0
    corners = [(x1 - m - w, y0 + m), (x0 + m, y0 + m), (x0 + m, y1 - m - h), (x1 - m - w, y1 - m - h)]

    def covered(c):
        cx, cy = c
        return int(np.count_nonzero((px >= cx) & (px <= cx + w) & (py >= cy) & (py <= cy + h)))

    lx, ly = min(corners, key=covered)
    out = [f"<rect x='{lx:.1f}' y='{ly:.1f}' width='{w:.1f}' height='{h:.1f}' rx='3' fill='white' "
           f"fill-opacity='0.85' stroke='#ccc'/>"]
    for i, s in enumerate(entries):
        yy = ly + pad + line_h * (i + 0.5)
        a, b = lx + pad, lx + pad + sample_w
        st = s.style
        if s.kind == "band":
            out.append(f"<rect x='{a:.1f}' y='{yy - 4:.1f}' width='{sample_w:.1f}' height='8' fill='{st['color']}'/>")
        elif s.kind == "points" or (s.kind == "line" and st.get("marker")):
            col = st["color"] if isinstance(st["color"], str) else COLORS["mid"]
            out.append(f"<circle cx='{(a + b) / 2:.1f}' cy='{yy:.1f}' r='3' fill='{col}'/>")
        else:
            dash = f" stroke-dasharray='{st['dash']}'" if st.get("dash") else ""
            op = f" stroke-opacity='{st['opacity']:g}'" if st.get("opacity", 1.0) != 1.0 else ""
            width = min(st["width"], 4.0)
            out.append(f"<path d='M{a:.1f} {yy:.1f}H{b:.1f}' stroke='{st['color']}' stroke-width='{width:g}'"
                       f"{dash}{op} fill='none'/>")
        out.append(_text(b + pad, yy, s.label, size=TICK_PX, anchor="start", baseline="central"))
    return "".join(out)


def _panel_svg(panel: Panel, box: tuple, clip_id: str) -> str:
    """The panel drawn in the pixel box ``(x0, y0, x1, y1)`` (the axes' frame)."""
    x0, y0, x1, y1 = box
    xs = [a for s in panel.series for a in _data_x(s)]
    ys = [a for s in panel.series for a in _data_y(s)]
    xall = np.concatenate([np.ravel(a) for a in xs]) if xs else np.zeros(0)
    yall = np.concatenate([np.ravel(a) for a in ys]) if ys else np.zeros(0)
    bars = panel.ycategories
    xlo, xhi = _limits(panel.xscale, xall, panel.xlim)
    if bars:
        ylo, yhi = -0.6, len(bars) - 0.4
    else:
        ylo, yhi = _limits(panel.yscale, yall, panel.ylim)
    sx = _Scale(panel.xscale, xlo, xhi, x0, x1)
    sy = _Scale("linear" if bars else panel.yscale, ylo, yhi, y1, y0)
    out = [f"<clipPath id='{clip_id}'><rect x='{x0:.1f}' y='{y0:.1f}' width='{x1 - x0:.1f}' "
           f"height='{y1 - y0:.1f}'/></clipPath>", f"<g clip-path='url(#{clip_id})'>"]
    for s in panel.series:
        st = s.style
        if s.kind == "band":
            a, b = sy(np.array(s.data))
            out.append(f"<rect x='{x0:.1f}' y='{min(a, b):.1f}' width='{x1 - x0:.1f}' height='{abs(b - a):.1f}' "
                       f"fill='{st['color']}'/>")
        elif s.kind == "hline":
            yy = float(sy(s.data[0]))
            out.append(f"<path d='M{x0:.1f} {yy:.1f}H{x1:.1f}' stroke='{st['color']}' stroke-width='{st['width']:g}'/>")
        elif s.kind == "line" and st.get("marker"):
            px, py = sx(s.data[0]), sy(s.data[1])
            ok = np.isfinite(px) & np.isfinite(py)
            out.append(f"<g fill='{st['color']}'>" + "".join(
                f"<circle cx='{a:.1f}' cy='{b:.1f}' r='3'/>" for a, b in zip(px[ok].tolist(), py[ok].tolist()))
                       + "</g>")
        elif s.kind == "line":
            dash = f" stroke-dasharray='{st['dash']}'" if st.get("dash") else ""
            op = f" stroke-opacity='{st['opacity']:g}'" if st["opacity"] != 1.0 else ""
            out.append(f"<path d='{_path(sx(s.data[0]), sy(s.data[1]))}' fill='none' stroke='{st['color']}' "
                       f"stroke-width='{st['width']:g}' stroke-linejoin='round'{dash}{op}/>")
        elif s.kind == "vlines":
            px, pa, pb = sx(s.data[0]), sy(s.data[1]), sy(s.data[2])
            ok = np.isfinite(px) & np.isfinite(pa) & np.isfinite(pb)
            d = "".join(f"M{x:.1f} {a:.1f}V{b:.1f}" for x, a, b in zip(px[ok].tolist(), pa[ok].tolist(),
                                                                      pb[ok].tolist()))
            out.append(f"<path d='{d}' stroke='{st['color']}' stroke-width='{st['width']:.1f}'/>")
        elif s.kind == "points":
            px, py = sx(s.data[0]), sy(s.data[1])
            ok = np.isfinite(px) & np.isfinite(py)
            r = st["radius"]
            if isinstance(st["color"], str):
                out.append(f"<g fill='{st['color']}'>" + "".join(
                    f"<circle cx='{a:.1f}' cy='{b:.1f}' r='{r:g}'/>" for a, b in zip(px[ok].tolist(), py[ok].tolist()))
                           + "</g>")
            else:
                cols = [c for c, good in zip(st["color"], ok.tolist()) if good]
                out.append("<g>" + "".join(f"<circle cx='{a:.1f}' cy='{b:.1f}' r='{r:g}' fill='{c}'/>"
                                            for a, b, c in zip(px[ok].tolist(), py[ok].tolist(), cols)) + "</g>")
        elif s.kind == "grid":
            xk, yk, colors = s.data
            pxe, pye = sx(_cell_edges(xk)), sy(_cell_edges(yk))
            cells = []
            for i in range(len(xk)):
                for j in range(len(yk)):
                    c = colors[i][j]
                    if c is None:
                        continue
                    a, b = float(pxe[i]), float(pxe[i + 1])
                    top, bot = float(min(pye[j], pye[j + 1])), float(max(pye[j], pye[j + 1]))
                    # a hair wider than the cell, so neighbours leave no seam
                    cells.append(f"<rect x='{a:.1f}' y='{top:.1f}' width='{b - a + 0.6:.1f}' "
                                 f"height='{bot - top + 0.6:.1f}' fill='{c}'/>")
            out.append(f"<g fill-opacity='{st['opacity']:g}'>" + "".join(cells) + "</g>")
        elif s.kind == "barh":
            vals = s.data[0]
            zero = float(sx(0.0))
            for k, (v, col, edge) in enumerate(zip(vals.tolist(), st["colors"], st["edges"])):
                if not math.isfinite(v):
                    continue
                xv = float(sx(v))
                yc = float(sy(k))
                hgt = 0.8 * abs(float(sy(0.0) - sy(1.0)))
                stroke = f" stroke='{edge}' stroke-width='1.5'" if edge else ""
                out.append(f"<rect x='{min(zero, xv):.1f}' y='{yc - hgt / 2:.1f}' width='{abs(xv - zero):.1f}' "
                           f"height='{hgt:.1f}' fill='{col}'{stroke}/>")
    out.append("</g>")
    # frame, ticks and their labels
    out.append(f"<rect x='{x0:.1f}' y='{y0:.1f}' width='{x1 - x0:.1f}' height='{y1 - y0:.1f}' fill='none' "
               f"stroke='#333' stroke-width='0.8'/>")
    ticks, labels, power = sx.ticks(panel.max_ticks)
    marks = []
    for t, lab in zip(ticks.tolist(), labels):
        xx = float(sx(t))
        marks.append(f"M{xx:.1f} {y1:.1f}v4")
        out.append(_text(xx, y1 + 6 + TICK_PX * 0.8, lab, size=TICK_PX))
    if power:
        out.append(_text(x1, y1 + 6 + TICK_PX * 1.9, "×" + _power_label(10.0 ** power), size=TICK_PX,
                         anchor="end"))
    widest = 0.0
    if bars:
        for k, lab in enumerate(bars):
            yy = float(sy(k))
            marks.append(f"M{x0:.1f} {yy:.1f}h-4")
            bold = "bold" if k < len(panel.ybold) and panel.ybold[k] else "normal"
            out.append(_text(x0 - 7, yy, lab, size=TICK_PX, anchor="end", baseline="central", weight=bold))
    else:
        ticks, labels, power = sy.ticks(panel.max_ticks)
        for t, lab in zip(ticks.tolist(), labels):
            yy = float(sy(t))
            marks.append(f"M{x0:.1f} {yy:.1f}h-4")
            out.append(_text(x0 - 7, yy, lab, size=TICK_PX, anchor="end", baseline="central"))
            widest = max(widest, _width(lab, TICK_PX))
        if power:
            out.append(_text(x0, y0 - 4, "×" + _power_label(10.0 ** power), size=TICK_PX, anchor="start"))
    out.append(f"<path d='{''.join(marks)}' stroke='#333' stroke-width='0.8'/>")
    if panel.title:
        out.append(_text((x0 + x1) / 2, y0 - 6 - (TICK_PX if power and not bars else 0), panel.title,
                         size=TITLE_PX))
    if panel.xlabel:
        out.append(_text((x0 + x1) / 2, y1 + 8 + TICK_PX + LABEL_PX, panel.xlabel, size=LABEL_PX))
    if panel.ylabel:
        xx = x0 - 10 - max(widest, 2 * TICK_PX) - 0.35 * LABEL_PX
        out.append(_text(xx, (y0 + y1) / 2, panel.ylabel, size=LABEL_PX, rotate=-90))
    if panel.colorbar is not None:
        lo, hi, label = panel.colorbar
        bx0, bx1 = x1 + 12, x1 + 24
        levels = np.linspace(lo, hi, 64)
        cols = colormap_rdbu(levels, lo, hi)
        hstep = (y1 - y0) / len(levels)
        out.append("".join(f"<rect x='{bx0:.1f}' y='{y1 - (k + 1) * hstep:.1f}' width='{bx1 - bx0:.1f}' "
                           f"height='{hstep + 0.5:.1f}' fill='{c}'/>" for k, c in enumerate(cols)))
        out.append(f"<rect x='{bx0:.1f}' y='{y0:.1f}' width='{bx1 - bx0:.1f}' height='{y1 - y0:.1f}' fill='none' "
                   f"stroke='#333' stroke-width='0.8'/>")
        cs = _Scale("linear", lo, hi, y1, y0)
        ticks, labels, power = cs.ticks(4)
        cw = 0.0
        for t, lab in zip(ticks.tolist(), labels):
            yy = float(cs(t))
            out.append(f"<path d='M{bx1:.1f} {yy:.1f}h4' stroke='#333' stroke-width='0.8'/>")
            out.append(_text(bx1 + 7, yy, lab, size=TICK_PX, anchor="start", baseline="central"))
            cw = max(cw, _width(lab, TICK_PX))
        if power:
            out.append(_text(bx0, y0 - 4, "×" + _power_label(10.0 ** power), size=TICK_PX, anchor="start"))
        # rotated a quarter turn back, the label's glyphs stand left of its baseline: one line height
        # right of the tick labels
        out.append(_text(bx1 + 10 + cw + 1.1 * LABEL_PX, (y0 + y1) / 2, label, size=LABEL_PX, rotate=-90))
    if panel.legend:
        out.append(_legend_svg(panel, box, sx, sy))
    return "".join(out)


def _y_tick_labels(panel: Panel) -> list[str]:
    """The labels the panel's y axis will carry (to leave room for them)."""
    if panel.ycategories:
        return list(panel.ycategories)
    ys = [a for s in panel.series for a in _data_y(s)]
    yall = np.concatenate([np.ravel(a) for a in ys]) if ys else np.zeros(0)
    lo, hi = _limits(panel.yscale, yall, panel.ylim)
    return _Scale(panel.yscale, lo, hi, 1.0, 0.0).ticks(panel.max_ticks)[1]


def _margins(panel: Panel) -> tuple[float, float, float, float]:
    """(left, right, top, bottom) room in px around a panel's frame for its labels."""
    widest = max([_width(t, TICK_PX) for t in _y_tick_labels(panel)] + [2 * TICK_PX])
    left = 12 + widest + (LABEL_PX * 1.6 if panel.ylabel else 0)
    right = 14 + (90.0 if panel.colorbar is not None else 0)
    top = 8 + (TITLE_PX * 1.4 if panel.title else 0) + TICK_PX
    bottom = 10 + TICK_PX * 2.2 + (LABEL_PX * 1.3 if panel.xlabel else 0)
    return left, right, top, bottom


def figure(panels: Sequence[Panel], *, cols: int, panel_width: float, panel_height: float,
           widths: Optional[Sequence[float]] = None, title: str = "") -> str:
    """The panels on a grid of ``cols`` columns, each cell ``panel_width`` x ``panel_height`` px
    (``widths``: relative column widths instead), as one SVG document with its size in px."""
    panels = list(panels)
    if not panels:
        raise ValueError("figure: no panels")
    rows = math.ceil(len(panels) / cols)
    rel = np.ones(cols) if widths is None else np.asarray(widths, float)
    col_w = rel / rel.sum() * panel_width * cols
    W, H = float(col_w.sum()), panel_height * rows
    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{W:.0f}' height='{H:.0f}' "
           f"viewBox='0 0 {W:.0f} {H:.0f}' font-family='{FONT}'>",
           f"<rect width='{W:.0f}' height='{H:.0f}' fill='white'/>"]
    if title:
        out.append(f"<title>{html.escape(title)}</title>")
    # margins shared by a column (left, right) and a row (top, bottom), so the frames line up
    m = np.zeros((rows, cols, 4))
    for k, p in enumerate(panels):
        m[divmod(k, cols)] = _margins(p)
    col_m, row_m = m.max(axis=0), m.max(axis=1)
    for k, p in enumerate(panels):
        r, c = divmod(k, cols)
        cx = float(col_w[:c].sum())
        left, right, top, bottom = col_m[c, 0], col_m[c, 1], row_m[r, 2], row_m[r, 3]
        box = (cx + left, r * panel_height + top, cx + col_w[c] - right, (r + 1) * panel_height - bottom)
        out.append(_panel_svg(p, box, f"c{k}"))
    out.append("</svg>")
    return "".join(out)
