"""Rerun recordings of a sweep and its identification (one ``log_*`` function per view).

Entities (all SI; the unit is in the entity name):

* ``runs/<run>/phi_rad``, ``runs/<run>/torque_Nm``: relative angle and drive torque over the
  logged period(s), timeline ``t_s`` (time since the first logged sample).
* ``phase_portrait/<run>``: ``(phi, phi'/omega)`` as a 2D line (both in rad, so a linear
  response is an ellipse of aspect ~1 at every frequency).
* ``restoring_force/true_Nm``, ``restoring_force/identified_Nm``: g(phi) of the true and the
  identified law over the measured range, timeline ``phi_urad`` (angle in micro-radians as
  the x axis).
* ``harmonics/<run>``: bar chart of |Phi_n|, n = 0..H (rad); ``harmonics_log10/<run>`` its log10.
* ``frf/M<amplitude>/h<n>_rad``: |Phi_n| against the drive frequency, timeline ``omega_mrad_s``.
* ``parameters``: markdown table true / identified / relative error / standard error.

``<run>`` is ``w<omega>_M<amplitude>`` (rad/s, N m).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np
import rerun as rr

from jointrig.vocab.law import JointLaw
from jointrig.identify.harmonics import fourier_coefficients
from jointrig.vocab.params import HINGE, Coordinate
from jointrig.vocab.records import SteadyStateRecord

__all__ = ["open_recording", "run_label", "log_run", "log_restoring_force", "log_harmonics", "log_parameter_table",
           "expected_entities", "sweep_blueprint", "unknown_law_blueprint", "silverbox_blueprint", "log_silverbox"]

APP_ID = "jointrig"


def run_label(omega_rad_s: float, amplitude_Nm: float) -> str:
    return f"w{omega_rad_s:g}_M{amplitude_Nm:g}".replace(".", "p")


def _label(record: SteadyStateRecord) -> str:
    return run_label(record.omega_rad_s, record.drive_amplitude_Nm)


def expected_entities(run_labels: Sequence[str]) -> set[str]:
    """Entity paths a sweep recording holds for these runs (see the module docstring)."""
    out = {"/parameters", "/restoring_force/true_Nm", "/restoring_force/identified_Nm"}
    for lab in run_labels:
        out |= {f"/runs/{lab}/phi_rad", f"/runs/{lab}/torque_Nm", f"/phase_portrait/{lab}",
                f"/harmonics/{lab}"}
    return out


@contextlib.contextmanager
def open_recording(rrd_path: Optional[Path], *, spawn: bool = False,
                   connect: Optional[str] = None) -> Iterator[rr.RecordingStream]:
    """A recording stream that writes ``rrd_path`` atomically (temp file, renamed on success)
    and optionally streams to a live viewer (``spawn``: start one; ``connect``: gRPC URL).

    Without a viewer the recording is held in memory and written by :func:`jointrig.files.write_atomic`
    (a full disk is then Python's own error, named with the file): rerun's file writer, on a full
    disk, only logs "File-writer thread shut down prematurely", and a flush after it could hang."""
    rec = rr.RecordingStream(APP_ID)
    sinks = []
    tmp = None
    memory = None
    if spawn:
        rr.spawn(connect=False)
        sinks.append(rr.GrpcSink())
    elif connect is not None:
        sinks.append(rr.GrpcSink(connect))
    if rrd_path is not None:
        rrd_path = Path(rrd_path)
        if sinks:
            from jointrig.files import temp_beside

            tmp = str(temp_beside(rrd_path))
            sinks.append(rr.FileSink(tmp))
        else:
            memory = rec.memory_recording()
    if sinks:
        rec.set_sinks(*sinks)
    ok = False
    try:
        yield rec
        ok = True
    finally:
        try:
            rec.flush()
            if memory is not None and ok:
                from jointrig.files import write_atomic

                data = memory.drain_as_bytes()
                write_atomic(rrd_path, lambda path: Path(path).write_bytes(data))
            rec.disconnect()
            if tmp is not None and ok:
                from jointrig.files import readable_mode

                os.chmod(tmp, readable_mode())
                os.replace(tmp, rrd_path)
        except Exception as err:  # rerun's file writer stops on a full disk ("shut down prematurely")
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            if ok and tmp is not None:
                import errno
                import shutil

                from jointrig.files import output_failed

                # rerun says only "File-writer thread shut down prematurely": ask the disk
                if shutil.disk_usage(rrd_path.parent).free < 1 << 20:
                    err = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                raise output_failed(rrd_path, err) from None
            raise
        if tmp is not None and not ok:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def sweep_blueprint(records: Sequence[SteadyStateRecord]):
    """The sweep recording's layout: first what the sweep answers (the identified restoring
    torque against the true one, on the timeline ``phi_urad``, which the time panel opens on,
    and the parameter table), then the frequency response per drive amplitude (timeline
    ``omega_mrad_s``), the runs over one period (timeline ``t_s``), the phase portraits and the
    harmonic spectra (log10), one named view per run. A view shows data only on its own
    timeline: each view's name says which one to pick in the time panel."""
    import rerun.blueprint as rrb

    everything = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())

    def whole(timeline):  # all the data, not the window around the time cursor
        return rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                                    end=rrb.TimeRangeBoundary.infinite())

    axis = rrb.TimeAxis(view_range=everything)  # the x axis spans it too

    amplitudes = sorted({r.drive_amplitude_Nm for r in records})
    labs = [(_label(r), f"{r.omega_rad_s:g} rad/s, {r.drive_amplitude_Nm:g} N m") for r in records]
    law = rrb.Horizontal(
        rrb.TimeSeriesView(origin="restoring_force",
                           name="restoring torque g(phi) [N m], identified vs true, against phi [urad] (timeline phi_urad)",
                           time_ranges=whole("phi_urad"), axis_x=axis),
        rrb.TextDocumentView(origin="parameters", name="parameters: true, identified, errors"),
        column_shares=[3, 2], name="Identified law")
    frf = rrb.Grid(*[rrb.TimeSeriesView(origin=f"frf/M{a:g}",
                                        name=f"|Phi_n| [rad] against omega [mrad/s] at M0 = {a:g} N m "
                                             f"(timeline omega_mrad_s)", time_ranges=whole("omega_mrad_s"), axis_x=axis)
                     for a in amplitudes],
                   name="Frequency response")
    runs = rrb.Grid(*[rrb.TimeSeriesView(origin=f"runs/{lab}", name=f"{title}: phi [rad], torque [N m] (timeline t_s)",
                                         time_ranges=whole("t_s"), axis_x=axis) for lab, title in labs],
                    name="Runs")
    portraits = rrb.Grid(*[rrb.Spatial2DView(origin=f"phase_portrait/{lab}", name=f"{title}: phi' / omega against phi [rad]")
                           for lab, title in labs], name="Phase portraits")
    spectra = rrb.Grid(*[rrb.BarChartView(origin=f"harmonics_log10/{lab}", name=f"{title}: log10 |Phi_n| [log10 rad]")
                         for lab, title in labs], name="Harmonic spectra")
    return rrb.Blueprint(rrb.Tabs(law, frf, runs, portraits, spectra),
                         rrb.TimePanel(timeline="phi_urad", state="collapsed"), collapse_panels=True)


def unknown_law_blueprint(with_damping: bool):
    """The unknown-law recording's layout: the identified restoring torque g(phi) with its 95%
    band, the true law and the best quintic (timeline ``phi_urad``), the fit's summary beside it,
    and, when a damping curve was fitted, f(phi') on the timeline ``rate_urad_s``."""
    import rerun.blueprint as rrb

    def whole(timeline):
        return rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                                    end=rrb.TimeRangeBoundary.infinite())

    axis = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                 end=rrb.TimeRangeBoundary.infinite()))
    tabs = [rrb.Horizontal(
        rrb.TimeSeriesView(origin="restoring_force", name="restoring torque g(phi) [N m]: identified, 95% band, "
                                                          "true, best quintic, against phi [urad] (timeline phi_urad)",
                           time_ranges=whole("phi_urad"), axis_x=axis),
        rrb.TextDocumentView(origin="parameters", name="hat fit"), column_shares=[3, 1], name="Restoring torque")]
    if with_damping:
        tabs.append(rrb.TimeSeriesView(origin="damping_force",
                                       name="damping torque f(phi') [N m]: identified, 95% band, true, against "
                                            "phi' [urad/s] (timeline rate_urad_s)",
                                       time_ranges=whole("rate_urad_s"), axis_x=axis))
    return rrb.Blueprint(rrb.Tabs(*tabs), rrb.TimePanel(timeline="phi_urad", state="collapsed"), collapse_panels=True)


def silverbox_blueprint():
    """The Silverbox recording's layout: the arrow test signal, measured and simulated output
    overlaid with the models' errors (timeline ``t_s``), the error table, and the residual
    spectra of the estimation data (log scale is the viewer's: bar charts of |Y_k| in V)."""
    import rerun.blueprint as rrb

    whole = rrb.VisibleTimeRange("t_s", start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    axis = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                 end=rrb.TimeRangeBoundary.infinite()))
    arrow = rrb.Horizontal(
        rrb.Vertical(
            rrb.TimeSeriesView(origin="arrow", contents=["arrow/measured_V", "arrow/nominal_V", "arrow/extended_V"],
                               name="arrow (test set) output [V]: measured, nominal, extended (timeline t_s)",
                               time_ranges=whole, axis_x=axis),
            rrb.TimeSeriesView(origin="arrow", contents=["arrow/nominal_error_V", "arrow/extended_error_V"],
                               name="simulated - measured [V] (timeline t_s)", time_ranges=whole, axis_x=axis)),
        rrb.TextDocumentView(origin="table", name="RMS error [mV] on the arrow"), column_shares=[5, 3],
        name="Arrow test")
    spectra = rrb.Horizontal(
        rrb.BarChartView(origin="estimation/residual_spectrum_nominal_V",
                         name="estimation residual |Y_k| [V], nominal, per multisine line"),
        rrb.BarChartView(origin="estimation/residual_spectrum_extended_V",
                         name="estimation residual |Y_k| [V], extended, per multisine line"),
        name="Residual spectra")
    return rrb.Blueprint(rrb.Tabs(arrow, spectra), rrb.TimePanel(timeline="t_s", state="collapsed"),
                         collapse_panels=True)


def log_silverbox(rec: rr.RecordingStream, fs_Hz: float, measured_V, nominal_V, extended_V,
                  residual_nominal_V, residual_extended_V, table_markdown: str) -> None:
    """The Silverbox recording, laid out by :func:`silverbox_blueprint`: the arrow's measured
    and simulated outputs and errors over ``t_s``, the residual spectra of the estimation data
    per multisine line, and the table of RMS errors."""
    rec.send_blueprint(silverbox_blueprint())
    t = rr.TimeColumn("t_s", duration=np.arange(np.size(measured_V)) / fs_Hz)
    for name, y in (("measured_V", measured_V), ("nominal_V", nominal_V), ("extended_V", extended_V),
                    ("nominal_error_V", np.asarray(nominal_V) - measured_V),
                    ("extended_error_V", np.asarray(extended_V) - measured_V)):
        rec.send_columns(f"arrow/{name}", indexes=[t], columns=rr.Scalars.columns(scalars=np.asarray(y, dtype=float)))
    rec.log("estimation/residual_spectrum_nominal_V", rr.BarChart(np.asarray(residual_nominal_V)), static=True)
    rec.log("estimation/residual_spectrum_extended_V", rr.BarChart(np.asarray(residual_extended_V)), static=True)
    rec.log("table", rr.TextDocument(table_markdown, media_type=rr.MediaType.MARKDOWN), static=True)


def log_run(rec: rr.RecordingStream, record: SteadyStateRecord) -> None:
    """Time series and phase portrait of one steady-state record."""
    lab = _label(record)
    t = rr.TimeColumn("t_s", duration=record.time_s - record.time_s[0])
    rec.send_columns(f"runs/{lab}/phi_rad", indexes=[t], columns=rr.Scalars.columns(scalars=record.phi_rad))
    rec.send_columns(f"runs/{lab}/torque_Nm", indexes=[t],
                     columns=rr.Scalars.columns(scalars=record.torque_Nm))
    rate = record.rate_rad_s
    if rate is not None:
        pts = np.column_stack([record.phi_rad, rate / record.omega_rad_s])
        rec.log(f"phase_portrait/{lab}", rr.LineStrips2D([np.vstack([pts, pts[:1]])]), static=True)


def log_harmonics(rec: rr.RecordingStream, records: Sequence[SteadyStateRecord], n_harmonics: int) -> None:
    """|Phi_n| per run (bar charts) and against frequency per amplitude (scalars)."""
    for r in records:
        amp = np.abs(fourier_coefficients(r.phi_rad, r.n_periods, n_harmonics))
        rec.log(f"harmonics/{_label(r)}", rr.BarChart(amp), static=True)
        # log10 for the spectra's view: on a linear scale only the fundamental shows
        rec.log(f"harmonics_log10/{_label(r)}", rr.BarChart(np.log10(np.maximum(amp, 1e-300))), static=True)
    for a in sorted({r.drive_amplitude_Nm for r in records}):
        group = sorted((r for r in records if r.drive_amplitude_Nm == a), key=lambda r: r.omega_rad_s)
        amps = np.array([np.abs(fourier_coefficients(r.phi_rad, r.n_periods, n_harmonics)) for r in group])
        idx = [rr.TimeColumn("omega_mrad_s", sequence=[round(1000 * r.omega_rad_s) for r in group])]
        for n in range(1, n_harmonics + 1, 2 if n_harmonics > 1 else 1):
            rec.send_columns(f"frf/M{a:g}/h{n}_rad", indexes=idx, columns=rr.Scalars.columns(scalars=amps[:, n]))


def log_restoring_force(rec: rr.RecordingStream, true_law: Optional[JointLaw], identified: JointLaw,
                        phi_range_rad: tuple[float, float], n_points: int = 401) -> None:
    """g(phi) of the identified law, and of the true law when known."""
    phi = np.linspace(*phi_range_rad, n_points)
    idx = [rr.TimeColumn("phi_urad", sequence=np.round(phi * 1e6).astype(np.int64))]
    laws = {"identified_Nm": identified}
    if true_law is not None:
        laws["true_Nm"] = true_law
    for name, law in laws.items():
        rec.send_columns(f"restoring_force/{name}", indexes=idx,
                         columns=rr.Scalars.columns(scalars=np.asarray(law.elastic_torque(phi), dtype=float)))


def log_restoring_band(rec: rr.RecordingStream, phi_rad: np.ndarray, g_Nm: np.ndarray, lower_Nm: np.ndarray,
                       upper_Nm: np.ndarray, true_law: Optional[JointLaw] = None,
                       others: Optional[dict[str, np.ndarray]] = None, *, entity: str = "restoring_force",
                       index: str = "phi_urad") -> None:
    """An identified restoring torque g(phi) with its confidence band (lower, upper), beside
    the true law when known and any other curves (e.g. the best polynomial), over phi. With
    ``entity="damping_force", index="rate_urad_s"`` the same for f(phi') over the rate (pass the
    true curve in ``others``)."""
    idx = [rr.TimeColumn(index, sequence=np.round(np.asarray(phi_rad) * 1e6).astype(np.int64))]
    curves = {"identified_Nm": g_Nm, "band_lower_Nm": lower_Nm, "band_upper_Nm": upper_Nm, **(others or {})}
    if true_law is not None:
        curves["true_Nm"] = np.asarray(true_law.elastic_torque(phi_rad), dtype=float)
    for name, y in curves.items():
        rec.send_columns(f"{entity}/{name}", indexes=idx,
                         columns=rr.Scalars.columns(scalars=np.asarray(y, dtype=float)))


def log_parameter_table(rec: rr.RecordingStream, markdown: str) -> None:
    rec.log("parameters", rr.TextDocument(markdown, media_type=rr.MediaType.MARKDOWN), static=True)



def log_misfit(rec, srf, smp, text: str, base: str = "diagnosis/misfit", words=None) -> None:
    """An unexplained misfit's restoring-force surface ``srf`` over its samples ``smp``:
    ``<base>/surface`` (supported knots as coloured squares at (phi, phi') normalised to +-1, y
    up, with the runs' loops), its sections over the timelines ``phi_urad`` and ``rate_urad_s``
    (micro-units of the place's angle or position), and ``text``, its description (markdown)."""
    import rerun as rr

    unit = words.torque_unit if words is not None else "N m"
    xs, vs = srf.phi_knots_rad, srf.rate_knots_rad_s
    top_x, top_v = float(xs[-1]), float(vs[-1])
    i, j = np.nonzero(srf.supported)
    val = srf.torque_Nm[i, j]
    top = max(float(np.max(np.abs(val))), 1e-300) if val.size else 1.0
    u = np.clip(val / top, -1, 1)
    # red for positive, blue for negative, white at zero (as the report's RdBu colour map)
    colours = np.column_stack([np.where(u > 0, 255, 255 * (1 + u)), 255 * (1 - np.abs(u)),
                               np.where(u < 0, 255, 255 * (1 - u))]).astype(np.uint8)
    rec.log(f"{base}/surface/knots", rr.Points2D(np.column_stack([xs[i] / top_x, -vs[j] / top_v]),
                                                          colors=colours, radii=1.0 / (xs.size - 1),
                                                          labels=[f"{v:.3g} {unit}" for v in val]), static=True)
    strips = []
    for phi, rate in zip(smp.phi_rad, smp.rate_rad_s):
        pts = np.column_stack([phi / top_x, -rate / top_v])
        strips.append(np.vstack([pts, pts[:1]]))
    rec.log(f"{base}/surface/loops", rr.LineStrips2D(strips, colors=[(90, 90, 90)]), static=True)
    for entity, index, (x, y) in (("stiffness_section_Nm", "phi_urad", srf.stiffness_section),
                                  ("damping_section_Nm", "rate_urad_s", srf.damping_section)):
        rec.log(f"{base}/{entity}", rr.SeriesLines(colors=[(128, 0, 128)], names=[entity]), static=True)
        rec.send_columns(f"{base}/{entity}",
                         indexes=[rr.TimeColumn(index, sequence=np.round(x * 1e6).astype(np.int64))],
                         columns=rr.Scalars.columns(scalars=np.asarray(y, dtype=float)))
    rec.log(f"{base}/description", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)


def misfit_text(character: str, surface: str, next_measurements) -> str:
    """A misfit's description as markdown: its character, its surface, what to measure next."""
    return (f"{character}.\n\n**Restoring-force surface:** {surface}.\n\n**Measurements that would tell more:**\n\n"
            + "\n".join(f"- {m}" for m in next_measurements))


def misfit_tab(base: str = "diagnosis/misfit", words=None, name: str = "Unexplained misfit"):
    """The blueprint tab of :func:`log_misfit`'s entities."""
    import rerun.blueprint as rrb

    from .misfit_words import JOINT_WORDS

    w = words or JOINT_WORDS
    axis = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                 end=rrb.TimeRangeBoundary.infinite()))
    whole = {t: rrb.VisibleTimeRange(t, start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
             for t in ("phi_urad", "rate_urad_s")}
    return rrb.Grid(
        rrb.Spatial2DView(origin=f"{base}/surface", name=f"residual surface over ({w.angle}, {w.angle}'), normalised; "
                                                         f"red +, blue - (loops in grey)"),
        rrb.TextDocumentView(origin=f"{base}/description", name="What the misfit looks like"),
        rrb.TimeSeriesView(origin=f"{base}/stiffness_section_Nm",
                           name=f"stiffness section S({w.angle}, 0) [{w.torque_unit}] (timeline phi_urad: "
                                f"u{w.angle_unit})", time_ranges=whole["phi_urad"], axis_x=axis),
        rrb.TimeSeriesView(origin=f"{base}/damping_section_Nm",
                           name=f"damping section S(0, {w.angle}') [{w.torque_unit}] (timeline rate_urad_s: "
                                f"u{w.angle_unit}/s)", time_ranges=whole["rate_urad_s"], axis_x=axis),
        grid_columns=2, name=name)


def chain_run_label(record) -> str:
    """A chain run's entity name: frequency, amplitude and driven flywheel."""
    driven = "".join(str(i + 1) for i, t in enumerate(record.torques_Nm) if t is not None)
    return f"{run_label(record.omega_rad_s, record.drive_amplitude_Nm)}_at{driven}"


def _twist_scale(records, j: int) -> float:
    """Largest |twist| of joint j (1-based) over the records (rad), the scale of its law's view."""
    return max(float(np.max(np.abs(r.angles_rad[j - 1] - r.angles_rad[j]))) for r in records)


def chain_blueprint(records, n_joints: int):
    """A chain sweep's layout: per joint, the identified restoring torque against the true one
    over its twist in per mille of its largest measured twist (timeline ``twist_permille``: one
    timeline for joints whose twists differ by decades), beside the parameter table; then every
    run's joint twists over one period (timeline ``t_s``)."""
    import rerun.blueprint as rrb

    everything = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())

    def whole(timeline):
        return rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                                    end=rrb.TimeRangeBoundary.infinite())

    axis = rrb.TimeAxis(view_range=everything)
    laws = rrb.Horizontal(
        rrb.Grid(*[rrb.TimeSeriesView(origin=f"restoring_force/joint{j}",
                                      name=f"joint {j}: restoring torque [N m], identified vs true, against its twist "
                                           f"in per mille of {1e3 * _twist_scale(records, j):.3g} mrad "
                                           f"(timeline twist_permille)",
                                      time_ranges=whole("twist_permille"), axis_x=axis) for j in range(1, n_joints + 1)]),
        rrb.TextDocumentView(origin="parameters", name="parameters: true, identified, errors"),
        column_shares=[3, 2], name="Identified joints")
    runs = rrb.Grid(*[rrb.TimeSeriesView(origin=f"runs/{chain_run_label(r)}",
                                         name=f"{r.omega_rad_s:g} rad/s, {r.drive_amplitude_Nm:g} N m: joint twists "
                                              f"[rad], drive torques [N m] (timeline t_s)",
                                         time_ranges=whole("t_s"), axis_x=axis) for r in records], name="Runs")
    return rrb.Blueprint(rrb.Tabs(laws, runs), rrb.TimePanel(timeline="twist_permille", state="collapsed"),
                         collapse_panels=True)


def log_chain_run(rec: rr.RecordingStream, record) -> None:
    """Every joint's twist and every recorded drive torque of one chain run, over its periods."""
    lab = chain_run_label(record)
    t = rr.TimeColumn("t_s", duration=record.time_s - record.time_s[0])
    for j in range(record.n_flywheels - 1):
        if record.angles_rad[j] is not None and record.angles_rad[j + 1] is not None:
            rec.send_columns(f"runs/{lab}/joint{j + 1}_twist_rad", indexes=[t],
                             columns=rr.Scalars.columns(scalars=record.angles_rad[j] - record.angles_rad[j + 1]))
    for i, tq in enumerate(record.torques_Nm, start=1):
        if tq is not None:
            rec.send_columns(f"runs/{lab}/drive{i}_torque_Nm", indexes=[t], columns=rr.Scalars.columns(scalars=tq))


def log_chain_laws(rec: rr.RecordingStream, true_laws, identified_laws, records, n_points: int = 401) -> None:
    """Each joint's restoring torque g(phi), identified and true, over its measured twist (on the
    timeline ``twist_permille``: per mille of the joint's largest twist, see :func:`chain_blueprint`)."""
    for j, (true, ident) in enumerate(zip(true_laws, identified_laws), start=1):
        scale = _twist_scale(records, j)
        per_mille = np.arange(-1000, 1001, 5)
        phi = per_mille * scale / 1000.0
        idx = [rr.TimeColumn("twist_permille", sequence=per_mille.astype(np.int64))]
        for name, law in (("identified_Nm", ident), ("true_Nm", true)):
            if law is not None:
                rec.send_columns(f"restoring_force/joint{j}/{name}", indexes=idx,
                                 columns=rr.Scalars.columns(scalars=np.asarray(law.elastic_torque(phi), dtype=float)))


def log_chain_diagnosis(rec: rr.RecordingStream, diagnosis, validation, n_flywheels: int, misfit=None,
                        text: str = "", kind: Coordinate = HINGE) -> None:
    """A chain diagnosis: the verdict and the report (``text``, the console's), where (the best
    score at every joint and flywheel, and the ranked candidates as a table), the held-out runs
    (the found joint's twist, measured against the nominal and the extended model, and each
    model's departure from the measurement), and an unexplained ``misfit``
    (:class:`identify.chain_diagnose.TrainMisfit`) as a restoring-force surface, with its blueprint."""
    import rerun.blueprint as rrb

    from .notes import rejection_text

    places = [f"joint {j}" for j in range(1, n_flywheels)] + [f"flywheel {i}" for i in range(1, n_flywheels + 1)]
    if any(s.where is not None and s.where.at_drive for s in diagnosis.first_round):
        places.append("drives")
    best = {p: 0.0 for p in places}
    for s in diagnosis.first_round:
        key = ("drives" if s.where is not None and s.where.at_drive
               else f"{'joint' if s.at_joint else 'flywheel'} {s.place}")
        if not s.note:
            best[key] = max(best[key], s.score)
    # log10(1 + score): one worn place dwarfs the rest on a linear axis
    rec.log("where/best_score_log10", rr.BarChart(np.log10(1.0 + np.array([best[p] for p in places]))), static=True)
    lines = ["| candidate | BIC score | p | magnitude | note |", "|---|---|---|---|---|"]
    for s in diagnosis.first_round:
        lines.append(f"| {s.label} | {s.score:.1f} | {s.p_value:.2g} | {s.magnitude[0]} = {s.magnitude[1]:.4g} +- "
                     f"{s.magnitude[2]:.2g} | {rejection_text(s.note, kind) if s.note else ''} |")
    found = "; ".join(f"**{s.label}**: {s.magnitude[0]} = {s.magnitude[1]:.4g} +- {s.magnitude[2]:.2g}"
                      for s in diagnosis.steps) or "nothing significant"
    gain = "" if validation is None else (f"\n\nHeld-out runs: twist error nominal {validation.nominal_error:.3g}, "
                                          f"extended {validation.extended_error:.3g}, gain **{validation.gain:.3g}**")
    head = (f"Found: {found}{gain}\n\nBars of the chart, left to right: " + ", ".join(places)
            + " (best score of any cause there, first round)\n\n")
    rec.log("where/candidates", rr.TextDocument(head + "\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)
    views = []
    if validation is not None and diagnosis.steps:
        from jointrig.studies.chain_validate import departure, found_motion

        step = diagnosis.steps[0]
        for k, (meas, nom, ext) in enumerate(validation.records):
            P, N = meas.n_periods, meas.samples_per_period
            what, x = found_motion(meas, step)
            t = rr.TimeColumn("t_s", duration=meas.time_s[:N] - meas.time_s[0])
            base = f"held_out/run{k + 1}"
            rec.send_columns(f"{base}/measured", indexes=[t], columns=rr.Scalars.columns(scalars=x.reshape(P, N).mean(axis=0)))
            for name, sim in (("nominal", nom), ("extended", ext)):
                ts = rr.TimeColumn("t_s", duration=sim.time_s - sim.time_s[0])
                rec.send_columns(f"{base}/{name}", indexes=[ts],
                                 columns=rr.Scalars.columns(scalars=found_motion(sim, step)[1]))
                rec.send_columns(f"departure/run{k + 1}/{name}", indexes=[t],
                                 columns=rr.Scalars.columns(scalars=departure(meas, sim, step, validation.band)))
            views.append(rrb.Vertical(
                rrb.TimeSeriesView(origin=base, name=f"held-out {meas.omega_rad_s:g} rad/s: {what} (SI), measured "
                                                     f"(period average) vs nominal vs extended (timeline t_s)"),
                rrb.TimeSeriesView(origin=f"departure/run{k + 1}",
                                   name=f"held-out {meas.omega_rad_s:g} rad/s: model minus measurement (harmonics "
                                        f"1..{validation.band})")))
    where = rrb.Horizontal(rrb.TextDocumentView(origin="where/candidates", name="found, and every candidate scored"),
                           rrb.BarChartView(origin="where/best_score_log10",
                                            name="log10(1 + best BIC score) per place: joints 1.., then flywheels 1.."),
                           column_shares=[3, 2], name="Where and what")
    tabs = [where] + ([rrb.Grid(*views, name="Held-out runs")] if views else [])
    if text:
        rec.log("verdict", rr.TextDocument(text, media_type=rr.MediaType.TEXT), static=True)
        tabs.insert(0, rrb.TextDocumentView(origin="verdict", name="Verdict and report"))
    if misfit is not None:
        from .misfit_words import measurement_text, misfit_texts, places_text, words_of

        character, surface = misfit_texts(misfit)
        words = words_of(misfit)
        log_misfit(rec, misfit.surface, misfit.samples,
                   f"**Where:** {places_text(misfit)}.\n\n" + misfit_text(
                       character, surface, [measurement_text(n, words) for n in misfit.next_measurements]),
                   base="misfit", words=words)
        tabs.insert(1, misfit_tab("misfit", words, name=f"Unexplained misfit at {misfit.where}"))
    rec.send_blueprint(rrb.Blueprint(rrb.Tabs(*tabs), rrb.TimePanel(timeline="t_s", state="collapsed"),
                                     collapse_panels=True))
