"""The report's SVG figures (present/svg.py): ticks, labels, geometry, legends, well-formed documents."""

import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from jointrig.present import svg

NS = {"s": "http://www.w3.org/2000/svg"}


@pytest.mark.parametrize("lo, hi", [(-0.0131, 0.0128), (0.0, 0.2514), (-1932.0, 1951.0), (3e-6, 9.7e-6),
                                    (-0.75, 20.75), (12.0, 13.0), (-5e7, 3e8)])
def test_nice_ticks_are_round_steps_inside_the_range(lo, hi):
    t = svg.nice_ticks(lo, hi, 4)
    assert 2 <= t.size <= 5
    assert t.min() >= lo and t.max() <= hi
    step = np.diff(t)
    assert np.allclose(step, step[0], rtol=1e-9)
    mantissa = step[0] / 10 ** math.floor(math.log10(step[0]))
    assert any(abs(mantissa - m) < 1e-9 for m in (1, 2, 2.5, 5)), mantissa
    # the smallest such step: the next smaller one would cut the range into more than 4 intervals
    assert (hi - lo) / step[0] <= 4 + 1e-9


def test_tick_labels_carry_the_decimals_of_their_step_and_factor_out_tiny_or_huge_powers():
    assert svg.tick_labels(np.array([0.0, 0.05, 0.1, 0.15])) == (["0.00", "0.05", "0.10", "0.15"], 0)
    assert svg.tick_labels(np.array([-0.01, 0.0, 0.01])) == (["\u22120.01", "0.00", "0.01"], 0)
    assert svg.tick_labels(np.array([-2000.0, -1000.0, 0.0, 1000.0])) == (["\u22122000", "\u22121000", "0", "1000"],
                                                                          0)
    assert svg.tick_labels(np.array([0.0, 1e-5, 2e-5])) == (["0", "1", "2"], -5)
    assert svg.tick_labels(np.array([0.0, 2.5e5, 5e5])) == (["0.0", "2.5", "5.0"], 5)


def test_log_ticks_are_decades_or_finer_when_the_view_is_narrow():
    assert np.allclose(svg.log_ticks(3e-6, 2e-2), [1e-5, 1e-4, 1e-3, 1e-2])
    assert np.allclose(svg.log_ticks(1.5e-4, 3e-3), [2e-4, 5e-4, 1e-3, 2e-3])
    with pytest.raises(ValueError, match="0 < lo < hi"):
        svg.log_ticks(0.0, 1.0)


def test_the_colour_scale_runs_blue_white_red_and_clips():
    assert svg.colormap_rdbu(np.array([-1.0, 0.0, 1.0, 5.0]), -1.0, 1.0) == ["#053061", "#f7f7f7", "#67001f",
                                                                             "#67001f"]


def _frame_and_path(doc):
    root = ET.fromstring(doc)
    frame = [r for r in root.iter("{http://www.w3.org/2000/svg}rect") if r.get("fill") == "none"][0]
    x0, y0 = float(frame.get("x")), float(frame.get("y"))
    x1, y1 = x0 + float(frame.get("width")), y0 + float(frame.get("height"))
    paths = [p for p in root.iter("{http://www.w3.org/2000/svg}path") if p.get("fill") == "none"]
    return root, (x0, y0, x1, y1), paths


def test_a_line_lands_where_its_data_are():
    # x from 0 to 1 and y from -2 to 2 with 5% margins: the first point at 0.05/1.1 of the
    # frame's width from its left, at the middle height for y = 0; pixels to 0.1
    x = np.linspace(0.0, 1.0, 11)
    y = np.where(np.arange(11) == 0, 0.0, 2.0 * np.sin(np.arange(11)))
    y[1], y[2] = -2.0, 2.0
    doc = svg.figure([svg.Panel("t").line(x, y, color="#000")], cols=1, panel_width=400, panel_height=300)
    _, (x0, y0, x1, y1), paths = _frame_and_path(doc)
    pts = np.array([[float(a), float(b)] for a, b in re.findall(r"[ML]([-\d.]+) ([-\d.]+)", paths[0].get("d"))])
    assert len(pts) == 11
    px = x0 + (x - (-0.05)) / 1.1 * (x1 - x0)
    py = y1 - (y - (-2.2)) / 4.4 * (y1 - y0)
    assert np.max(np.abs(pts[:, 0] - px)) <= 0.051 and np.max(np.abs(pts[:, 1] - py)) <= 0.051


def test_a_line_breaks_where_it_is_not_finite_and_text_is_escaped():
    y = np.array([0.0, 1.0, np.nan, 2.0, 3.0])
    doc = svg.figure([svg.Panel("a < b & c").line(np.arange(5.0), y, color="#000")], cols=1, panel_width=300,
                     panel_height=200)
    _, _, paths = _frame_and_path(doc)
    assert paths[0].get("d").count("M") == 2 and paths[0].get("d").count("L") == 2
    assert any(t.text == "a < b & c" for t in ET.fromstring(doc).iter("{http://www.w3.org/2000/svg}text"))


def test_the_legend_goes_to_the_corner_the_data_leave_free():
    # data crowd the upper half: the legend goes to a lower corner
    x = np.linspace(0, 1, 400)
    y = 0.6 + 0.4 * np.random.default_rng(0).random(x.size)
    y[0] = 0.0
    doc = svg.figure([svg.Panel(legend=True).line(x, y, color="#000", label="measured")], cols=1,
                     panel_width=400, panel_height=300)
    root, (x0, y0, x1, y1), _ = _frame_and_path(doc)
    box = [r for r in root.iter("{http://www.w3.org/2000/svg}rect") if r.get("fill") == "white" and r.get("rx")][0]
    assert float(box.get("y")) > (y0 + y1) / 2


def test_log_and_symlog_axes_and_every_kind_of_element_make_a_well_formed_document():
    p = svg.Panel("residuals", "n", "|r| [rad]", yscale="log", ylim=(1e-6, None), legend=True)
    p.vlines(np.arange(5), 1e-6, [1e-3, 2e-4, 1e-5, 3e-6, 5e-4], color="#d62728", width=4, label="nominal")
    q = svg.Panel("surface", "phi", "rate", colorbar=(-2.0, 2.0, "torque [N m]"))
    q.grid([0.0, 1.0, 2.0], [0.0, 1.0], [["#ff0000", None], [None, "#00ff00"], ["#0000ff", "#ffffff"]], opacity=0.4)
    q.points([0.5, 1.5], [0.2, 0.8], color=["#000000", "#111111"])
    q.band(-0.1, 0.1, color="#ddd", label="band")
    q.hline(0.0, color="#aaa")
    c = svg.Panel(xlabel="score", xscale="symlog", ycategories=("a", "b (adopted)"), ybold=(False, True))
    c.barh([-12.0, 3755.0], colors=["#777", "#1f77b4"], edges=[None, "#000"])
    doc = svg.figure([p, q, c], cols=3, panel_width=300, panel_height=250, title="all")
    root = ET.fromstring(doc)
    texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "10⁻⁴" in texts and "10³" in texts and "−10" in texts and "0" in texts
    assert root.get("width") == "900" and root.get("height") == "250"
    assert len(list(root.iter("{http://www.w3.org/2000/svg}clipPath"))) == 3


def test_bad_ranges_are_refused_by_name():
    with pytest.raises(ValueError, match="nice_ticks: expected finite lo < hi"):
        svg.nice_ticks(1.0, 1.0)
    with pytest.raises(ValueError, match="figure: no panels"):
        svg.figure([], cols=1, panel_width=100, panel_height=100)


def test_degenerate_data_still_make_a_readable_panel():
    # a constant line (no range), a lower limit fixed above all the data, a line with no
    # finite value, a log axis with zeros and negatives: limits padded, room made, defaults
    # taken, the non-positive values left out
    panels = [svg.Panel("flat").line([0.0, 1.0, 2.0], [5.0, 5.0, 5.0], color="#000"),
              svg.Panel("above", ylim=(10.0, None)).line([0.0, 1.0], [1.0, 2.0], color="#000"),
              svg.Panel("empty").line([0.0, 1.0], [np.nan, np.inf], color="#000"),
              svg.Panel("log", yscale="log").line([0.0, 1.0, 2.0, 3.0], [0.0, -1.0, 1e-3, 1e-1], color="#000")]
    root = ET.fromstring(svg.figure(panels, cols=4, panel_width=300, panel_height=200))
    texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "5.0" in texts or "5.00" in texts, texts
    assert {"10.0", "15.0", "20.0"} <= set(texts)  # 10 to 20 above the fixed 10
    assert "10⁻³" in texts and "10⁻¹" in texts
    d = [p.get("d") for p in root.iter("{http://www.w3.org/2000/svg}path") if p.get("fill") == "none"]
    assert d[2] == "" and d[3].count("M") == 1 and d[3].count("L") == 1  # only the two positive points
