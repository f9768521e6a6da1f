"""What a drive train's diagnosis says, as text and JSON (pure): ``jointrig diagnose`` on a
train's file, and the demo ``jointrig diagnose-chain``.

The text opens on the verdict and, with the user's model (``--model``), on each parameter as
written beside what the data say; then the place and size of every cause found, the candidates
ranked, and the held-out runs' error in the rig.
"""

from __future__ import annotations

import math
import re
from typing import Sequence

from jointrig.identify.chain_diagnose import zero_resolved
from jointrig.studies.chain_validate import TrainReport


from .diagnosis_json import DiagnosisJson, FitJson, RunJson, ValidationJson
from .formatting import interval_text, quantity_of, sig, sig_or, unit_of, with_se
from .misfit_words import character_json, measurement_text, misfit_texts, places_text, surface_json, words_of
from .notes import bias_unmeasured_text, failures_text, generalisation_text, note_text, plausibility_text, rejection_text
from .summary import NO_GAIN, compare_written, steps_after, wrong_sentence
from .text import (ValidationRow, ambiguity_lines, causes_lines, head_lines, notes_lines, on_bound_lines, parameter_lines,
                   ruled_out_lines, validation_lines)


__all__ = ["format_train_report", "plain_train_verdict", "train_report_json", "train_figure",
           "write_train_html"]


def _notes(notes: Sequence, report: TrainReport) -> list[str]:
    """The reader's notes, then the diagnosis's, in words (:func:`present.notes.note_text`)."""
    return [note_text(n) for n in (*notes, *report.notes)]


def _written(report: TrainReport) -> tuple:
    """The user's model as written beside the adopted fit (else the nominal one), provisional
    where no model explains the data (:func:`present.summary.compare_written`)."""
    return compare_written(report.written, report.adopted_fit, report.verdict.verdict == "unexplained")


def _taken(report: TrainReport) -> dict:
    """Per joint's zero parameter, the constant its twist's mean took out before the fit
    (:mod:`identify.zeros`): the fit's zero is read on top of it."""
    zs = report.zeros
    if zs is None or zs.kept:
        return {}
    return {f"joint{j}_angle_offset_rad": zs.angles[j - 1] - zs.angles[j] for j in range(1, len(zs.angles))}


def reported_values(fit, report: TrainReport) -> dict:
    """Every parameter of a chain fit with its standard error, as the JSON lists them
    (:meth:`ChainFit.parameters`: the linear ones, then what the terms imply and the profiled),
    each twist's zero as it reads on the user's sensors (:func:`_taken`)."""
    added = _taken(report)
    return {n: (v + added.get(n, 0.0), fit.std_error(n)) for n, v in fit.parameters().items()}


def reported_intervals(fit) -> dict:
    """Every parameter's 95% interval as :func:`reported_values` lists them: ``(half width,
    degrees of freedom of its standard error)`` (:meth:`identify.estimates.Estimates.interval`;
    inf where the error is taken as known)."""
    return {n: (fit.interval(n), fit.std_error_dof(n)) for n in fit.parameters()}


def plain_label(step, form: str = "train") -> str:
    """A cause found, in plain words at its place ("dry friction at joint 1"); in the
    relative-angle form (``form``) body 1's law to ground is the joint's ("dry friction in the
    joint")."""
    from jointrig.identify.causes import by_name

    plain = by_name(step.effect).plain or step.effect
    if step.where is None:
        return plain
    if form == "relative" and step.where.to_ground:
        return f"{plain} in the joint"
    return f"{plain} {step.where.describe()}"


def _measurements(misfit) -> tuple[str, ...]:
    """The measurements that would tell more about a train's misfit, in its place's words."""
    return tuple(measurement_text(n, words_of(misfit)) for n in misfit.next_measurements)


def plain_train_verdict(report: TrainReport) -> str:
    """The verdict in words, after the parameters of the user's model the data contradict."""
    v, d, val = report.verdict, report.diagnosis, report.validation
    nm = report.kind.name
    wrong = wrong_sentence(_written(report), nm)
    held = "later periods of the runs" if report.held_out_periods else "runs it was not fitted on"
    if v.verdict == "no_misfit":
        return wrong + "The model's structure explains the data: no cause at any joint or body is missing."
    if v.verdict == "explained":
        final = reported_values(d.final, report)

        def size(s) -> tuple:  # in the final fit; a magnitude made of parts (an amplitude) as scored
            v, se = final.get(s.magnitude[0], (math.nan, math.nan))
            return (v, se) if math.isfinite(se) else tuple(s.magnitude[1:])
        found = "; ".join(f"{plain_label(s, report.form)} ({quantity_of(nm(s.magnitude[0]))} {with_se(*size(s))}"
                          f" {unit_of(nm(s.magnitude[0]))})" for s in d.steps)
        better = (f"{val.gain:.3g} times better than without" if math.isfinite(val.gain) else
                  "where the model without it reaches no steady state")
        them = "them" if len(d.steps) > 1 else "it"
        c2 = d.reduced_chi2(d.final)
        fits = (f"the model fits the runs to their noise (chi2/dof {c2:.2g}: about 1 when only noise is left)"
                if c2 < 1.5 else f"the model fits the runs to chi2/dof {c2:.2g} (about 1 when only noise is left)")
        return (wrong + f"Your model misses {found}. With {them}, {fits}, and simulated in the rig it predicts the "
                f"{held} {better} (at {val.extended_error / val.expected_error:.2g} times what a right model misses "
                f"there, at most {val.bound:.2g})." + _untold(d))
    return wrong + ("A significant misfit remains that no catalogued cause at any joint or body explains; the "
                    "candidates below are ranked by evidence, none is adopted.")


def _untold(d) -> str:
    """What the verdict's name stands beside: each adopted cause the data cannot tell from
    another (:attr:`ChainDiagnosis.ambiguities`), in a sentence ("" where there is none)."""
    out = []
    for step in d.steps:
        others = [o for a in d.ambiguities if step.label in a.effects for o in a.effects if o != step.label]
        if others:
            out.append(f" These runs cannot tell {step.label} from {' or '.join(others)} (what would: below).")
    return "".join(out)


def _right_parts(val) -> str:
    """What a right model's held-out error is made of, and the bound on a right model's ratio, in
    words ("" where it was not measured)."""
    r = val.right
    if r is None:
        return ""
    method = (f"the method's bias {sig(math.sqrt(r.method), 2)}" if r.unmeasured is None else
              f"the method's bias not measured: {bias_unmeasured_text(r.unmeasured)}")
    return (f": the noise {sig(math.sqrt(r.noise), 2)}, the parameters' and the drive's uncertainty "
            f"{sig(math.sqrt(r.propagated), 2)} ({r.directions} directions, {r.draws} draws of the drive), {method}; a right model stays within "
            f"{r.bound:.3g} times it but with probability {r.alpha:g} ({r.dof:.3g} components, estimated with "
            f"{r.estimate_dof:.3g} degrees of freedom)")


def _sought(report: TrainReport) -> str:
    """Where the causes were sought, in words."""
    d = report.diagnosis
    N = d.nominal.spec.n_flywheels
    n_joint = sum(1 for s in d.first_round if s.at_joint)
    n_ground = sum(1 for s in d.first_round if s.ground)
    n_drive = sum(1 for s in d.first_round if s.where is not None and s.where.at_drive)
    n_channel = sum(1 for s in d.first_round if s.where is not None and s.where.at_channel)
    n_drag = len(d.first_round) - n_joint - n_ground - n_drive - n_channel
    places = ([f"{n_joint} at {N - 1} joint(s)"] if N > 1 else []) + (
        [f"viscous drag at {n_drag} {'bodies' if n_drag > 1 else 'body'}"] if n_drag else []) + (
        [f"{n_ground} laws to ground"] if n_ground else []) + (
        ["the drives' lag"] if n_drive else []) + (
        [f"skew and scale of {n_channel // 2} angle channel(s)"] if n_channel else [])
    return f"{len(d.first_round)} candidates: {', '.join(places)}"


#: The largest zero offset of a twist or an angle read as a sensor's (rad, about 11 deg): beyond
#: it an even stiffness is taken as the joint's.
MAX_ZERO_OFFSET_RAD = 0.2
#: With ``--zeroed``, a mean twist above this (rad) is said to contradict it (a sensor's zero error
#: of :data:`identify.causes.ANGLE_ZERO_TOLERANCE_RAD` is a bench's own).
MAX_ZEROED_TWIST_RAD = 0.01
#: A drive's mean below this share of its amplitude is not reported (a DAQ's offset of that size
#: is within the sensors' class).
TORQUE_MEAN_SHARE = 1e-3


def _torque_means(report: TrainReport) -> list[str]:
    """Each drive's mean over the fitted runs where it stands out of its run-to-run spread: on a
    train free to turn (a carriage free to move), the sensor's offset or a constant load where the
    drive acts, which the data cannot tell apart (a periodic steady state carries no net mean
    force); where a body is tied to the frame by a spring, a load or the offset."""
    zs = report.zeros
    if zs is None:
        return []
    kind = report.kind
    amp = max((s[1] for s in report.settings), default=math.nan)
    tied = report.form != "relative" and any(any(t.elastic for t in g) for g in report.diagnosis.nominal.spec.grounds)
    out = []
    for i, (m, se) in enumerate(zip(zs.torques, zs.torque_se), start=1):
        if not math.isfinite(m) or not abs(m) > max(3 * se if math.isfinite(se) else 0.0, TORQUE_MEAN_SHARE * amp):
            continue
        what, unit = kind.drive, kind.drive_unit
        err = f" +- {se:.2g}" if math.isfinite(se) else ""
        fit = report.diagnosis.final if report.verdict.verdict == "explained" else report.diagnosis.nominal
        name = f"ground{i}_constant_torque_Nm"
        if name in fit.names:
            k = fit.names.index(name)
            what_k = kind.drive
            out.append(f"the drive {what} on body {i} averages {m:.4g}{err} {unit} over the fitted runs; the fit reads "
                       f"a constant {what_k} against it of {with_se(float(fit.values[k]), float(fit.std_errors[k]))} "
                       f"{unit} (ground{i}_constant_{what_k}): the sensor's offset plus a constant load where the drive "
                       f"acts (gravity on the axis, a cable's drag; the data cannot tell the two apart), balanced "
                       f"where body {i} slides (it may stick) and held as a load in every replay")
            continue
        if tied:
            why = ("a load on the body or the sensor's offset (a spring to the frame can carry either): the fit leaves it "
                   "out, and the replays hold each run's mean position with the constant the model reads")
        else:
            why = (f"a {kind.free_line} carries no net mean {what} in a "
                   f"steady state, so that is the sensor's offset or a constant load where the drive acts (gravity on "
                   f"the axis, a cable's drag); the fit leaves it out, and the replays hold each run's mean "
                   f"{kind.relative_motion} with the constants the model reads")
        out.append(f"the drive {what} on body {i} averages {m:.4g}{err} {unit} over the fitted runs: {why}")
        held = _held_load(report, i)
        if held is not None and not tied:
            load, load_se = held
            rest, rest_se = m - load, math.hypot(se if math.isfinite(se) else 0.0, load_se)
            out.append(f"of it, the joints beside body {i} carry {with_se(load, load_se)} {unit} away by their laws at "
                       f"the measured mean twists (a load beyond them); the rest, {with_se(rest, rest_se)} {unit}, is "
                       f"the sensor's offset or a load on body {i} itself")
    return out


#: A parameter that the balance itself moves by more than this many standard errors on its
#: model's noise-free replay is named, with more harmonics as the remedy.
METHOD_BIAS_SE = 2.0


def method_bias_steps(report: TrainReport) -> tuple[str, ...]:
    """Where the balance's own bias (:attr:`ChainValidation.method_bias`: the adopted model refitted
    on its noise-free replay) moves a parameter by more than :data:`METHOD_BIAS_SE` standard
    errors: what it reads, and more harmonics as the remedy (stick-slip and kinks put content
    above the band, which the balance of a masked equation misses: a servo carriage's mass read
    4% high at harmonics 1..20 and within 0.3% at 1..40)."""
    val = report.validation
    if val is None or not val.method_bias:
        return ()
    nm = report.kind.name
    off = [(n, b, e) for n, b, e in val.method_bias if e > 0 and math.isfinite(b) and abs(b) > METHOD_BIAS_SE * e]
    if not off:
        return ()
    band = report.diagnosis.n_harmonics
    listed = ", ".join(f"{quantity_of(nm(n))} by {b:+.3g} {unit_of(nm(n))} ({b / e:+.1f} standard errors)"
                       for n, b, e in off)
    return (f"on the noise-free replay of this model the balance itself moves {listed}: harmonics 1..{band} miss "
            f"what the motion's kinks put above them, and the fit above carries that bias; fit more harmonics "
            f"(--band {2 * band}) where the records hold them (the notes give each run's harmonics) and compare the "
            f"two",)


def _held_load(report: TrainReport, i: int):
    """The mean torque the joints beside body ``i`` carry away from it by their laws at the
    measured mean twists (:attr:`TrainReport.preloads`), with its standard error (the two joints'
    in quadrature); None unless every joint beside it has its zero read from the data."""
    q = {j: (v, e) for j, v, e, _ in report.preloads}
    n = report.diagnosis.nominal.spec.n_flywheels
    beside = [j for j in (i - 1, i) if 1 <= j <= n - 1]
    if not beside or not all(j in q for j in beside):
        return None
    load = sum(q[j][0] * (1 if j == i else -1) for j in beside)
    return load, math.sqrt(sum(q[j][1] ** 2 for j in beside))


def offset_readings(report: TrainReport) -> tuple[str, ...]:
    """What the sensors read at rest, one reading in words per channel where it matters (pure):
    each joint's twist (the constant taken out before the diagnosis, :mod:`identify.zeros`, plus
    the zero the fit reads where the joint's law needs one), the drive's mean, and where an even
    stiffness ``a phi^2`` is tried or adopted beside a cubic ``gamma phi^3``, the zero offset
    ``delta = -a / (3 gamma)`` it is, to first order, of the angle the law reads: the data cannot
    tell the two apart, and an encoder's zero is the likelier."""
    from jointrig.identify.causes import by_name
    from jointrig.vocab.law import Power

    d = report.diagnosis
    p = d.final.as_dict()
    out = []
    kind = report.kind
    nm = kind.name
    cubic = Power(3).name
    x = kind.position
    length = unit_of(nm("joint1_backlash_half_gap_rad"))
    sensors = f"{kind.sensor} sensors"
    zs = report.zeros
    taken = {}  # per joint number: the constant taken out of its twist before the diagnosis
    if zs is not None and not zs.kept:
        taken = {j: zs.angles[j - 1] - zs.angles[j] for j in range(1, len(zs.angles))}
    zeros = {n: v + _taken(report).get(n, 0.0) for n, v, _ in d.final.profiled
             if re.fullmatch(r"joint\d+_angle_offset_rad", n)}
    even = {s.magnitude[0][: -len(by_name(s.effect).magnitude)] for s in d.steps if by_name(s.effect).reads_as_offset}
    fitted = {n: e for n, _, e in d.final.profiled}
    # each twist's zero: the mean taken out, plus what the fit reads under a nonlinear law (beside an
    # even stiffness at the same joint the two are read together, below)
    for i in range(1, (len(zs.angles) if zs is not None else d.final.spec.n_flywheels)):
        name = f"joint{i}_angle_offset_rad"
        if f"joint{i}_" in even:
            continue
        if name in zeros and zero_resolved(d.final, i):
            value, se = zeros[name], fitted[name]
        elif zs is not None and not zs.kept and math.isfinite(zs.twists[i - 1]):
            value, se = zs.twists[i - 1], zs.twist_se[i - 1]
        else:
            continue
        if not (abs(value) > 3 * se if math.isfinite(se) else abs(value) > 0):
            continue
        degrees = kind.in_degrees(value)
        err = f" +- {se:.2g}" if math.isfinite(se) else ""
        if name in zeros and zero_resolved(d.final, i):
            out.append(f"the twist of joint {i} ({x}{i} - {x}{i + 1}) reads {value:.4g}{err} {length}{degrees} at "
                       f"rest: the {sensors} were not zeroed together (the fit reads the joint's law from the twist "
                       f"minus it)")
        else:
            out.append(f"the twist of joint {i} ({x}{i} - {x}{i + 1}) averages {value:.4g}{err} {length}{degrees} over "
                       f"the fitted runs: the {sensors}' zeros and any preload's twist together (the joint's law does "
                       f"not show where its zero is, so it is taken out before the fit)")
    if zs is not None and zs.kept:
        for i, (m, se) in enumerate(zip(zs.twists, zs.twist_se), start=1):
            if math.isfinite(m) and abs(m) > max(3 * se if math.isfinite(se) else 0.0, MAX_ZEROED_TWIST_RAD):
                out.append(f"you said the {sensors} were zeroed together (--zeroed), but the twist of joint {i} "
                           f"({x}{i} - {x}{i + 1}) averages {m:.4g} {length} over the fitted runs: if nothing preloads "
                           f"the joint, they were not, and the diagnosis without --zeroed takes each zero from the data")
    if report.form == "relative" and zs is not None and not zs.kept:
        value, se = zs.angles[0], zs.angle_se[0]
        if abs(value) > 3 * se if math.isfinite(se) else abs(value) > 0:
            err = f" +- {se:.2g}" if math.isfinite(se) else ""
            out.append(f"the relative angle (phi) averages {value:.4g}{err} {length} ({math.degrees(value):.3g} deg) "
                       f"over the fitted runs: its zero, taken out before the fit (a symmetric joint twists about its "
                       f"rest)")
    what, unit = kind.drive, kind.drive_unit
    for j, q, se, by_run in report.preloads:
        spread = max(by_run) - min(by_run) if by_run else 0.0
        varies = math.isfinite(se) and spread > 3 * se * math.sqrt(len(by_run))
        if math.isfinite(q) and (abs(q) > (3 * se if math.isfinite(se) else 0.0) or varies):
            out.append(f"joint {j} carries a mean {what} of {with_se(q, se)} {unit} over the fitted runs"
                       + (f" (from {min(by_run):.4g} to {max(by_run):.4g} {unit} by run: a load that changes between "
                          f"runs)" if varies else "")
                       + ": a preload, the mean load passed through it between the drive and a load beyond (read from "
                         "its law at the measured mean twist; each run's replay holds its own)")
    out += _torque_means(report)
    for s in d.steps:
        cause = by_name(s.effect)
        if not cause.reads_as_offset:
            continue
        prefix = s.magnitude[0][: -len(cause.magnitude)]
        a, gamma = p.get(prefix + cause.magnitude), p.get(prefix + cubic)
        if not a or not gamma or gamma <= 0:
            continue
        # gamma (phi - delta)^3 = gamma phi^3 - 3 gamma delta phi^2 + ...; beside the twist's zero
        # the nominal model holds already (within a sensor's range), the two add up
        delta = -a / (3 * gamma) + zeros.get(prefix + "angle_offset_rad", 0.0)
        if prefix.startswith("joint") and prefix + "angle_offset_rad" not in zeros:
            delta += taken.get(int(prefix[5:-1]), 0.0)
        elif prefix.startswith("ground") and zs is not None and not zs.kept:
            delta += zs.angles[int(prefix[6:-1]) - 1]
        if abs(delta) > MAX_ZERO_OFFSET_RAD:
            continue
        place = re.fullmatch(r"(joint|ground)(\d+)_", prefix)
        i = int(place.group(2))
        if place.group(1) == "joint":
            what = f"the twist of joint {i} ({x}{i} - {x}{i + 1})"
        elif report.form == "relative":
            what = "the relative angle (phi)"
        else:
            what = f"body {i}'s {kind.sensor} ({x}{i})"
        unit = lambda n: unit_of(nm(prefix + n))  # noqa: E731
        length = unit("backlash_half_gap_rad")
        degrees = kind.in_degrees(delta, 2)
        out.append(f"the even stiffness a = {a:.4g} {unit(cause.magnitude)} is exactly what a zero offset of {what} of "
                   f"-a / (3 gamma) = {delta:.3g} {length}{degrees} makes of the cubic gamma = {gamma:.4g} "
                   f"{unit(cubic)}: the data cannot tell the two apart. If the joint is symmetric, {what} reads "
                   f"{delta:.3g} {length} at rest and there is no even stiffness; to tell, read {what} at rest "
                   f"without torque, zero the {kind.sensor} sensors there and run the "
                   f"diagnosis again with --zeroed")
    return tuple(out)


def _plausibility(report: TrainReport) -> tuple[str, ...]:
    """What the nominal fit says about how the file was read, in words (:func:`present.notes.plausibility_text`)."""
    return tuple(plausibility_text(f, report.kind) for f in report.diagnosis.plausibility)


def _cell(error: float) -> str:
    return sig_or(error, "no steady")


def format_train_report(report: TrainReport, *, source: str = "", notes: Sequence[str] = (), shown: int = 6) -> str:
    """A train's (or a single axis's) diagnosis as text, in the layout of every bench
    (:mod:`present.text`); the causes table shows the significant ones and the best ``shown``."""
    d, v, val = report.diagnosis, report.verdict, report.validation
    N = d.nominal.spec.n_flywheels
    nm = report.kind.name
    fit_ids = [r for i, r in enumerate(report.run_ids) if i not in report.held_out]
    held_ids = [report.run_ids[i] for i in report.held_out]
    m = report.misfit
    if v.verdict != "unexplained":
        steps = _plausibility(report) + offset_readings(report) + method_bias_steps(report) + steps_after(
            v.verdict, d.ambiguities, report.held_out_periods)
    else:  # no cause mends a file read wrong: that comes first
        steps = _plausibility(report) + offset_readings(report) + (_measurements(m) if m is not None else ())
    misfit = ([f"Where the misfit is: {places_text(m)}",
               f"What the misfit looks like there: {misfit_texts(m)[0]}",
               f"Its restoring-force surface: {misfit_texts(m)[1]}"] if m is not None else [])
    lines = head_lines(v, plain_train_verdict(report), steps, name=nm, model=report.model_path or "",
                       written=_written(report), misfit=misfit)
    kind = report.kind
    what = f"a single body on a {kind}" if N == 1 else kind.bodies(N)
    lines += ["", f"Diagnosis of {source or 'the runs'}: {what}, {len(report.run_ids)} run(s), harmonics "
                  f"1..{d.n_harmonics}"]
    if report.held_out_periods:
        lines.append(f"  fit on the earlier periods of run(s) {', '.join(report.run_ids)}; held out: their later periods")
    else:
        lines.append(f"  fit on runs {', '.join(fit_ids)}; held out for validation: {', '.join(held_ids)}")
    units = (kind.drive_unit, kind.unit)
    lines.append("  noise per sample (from period-to-period variation): "
                 + ", ".join(f"{report.kind.channel(k)} {sig(x, 2)} {units[0] if k.startswith('torque') else units[1]}"
                             for k, x in d.noise_std.items()))
    lines.append(f"  model fidelity (added to each row's noise variance): "
                 f"{fidelity_statement(d.fidelity, report.run_ids if report.held_out_periods else fit_ids)}")
    all_notes = _notes(notes, report)
    if all_notes:
        lines.append(f"  {len(all_notes)} note(s) on the data: at the end")
    lines += ["", f"Nominal model: chi2/dof = {d.reduced_chi2(d.nominal):.3g} (about 1 when only noise is left)"]
    lines += parameter_lines(reported_values(d.nominal, report), reported_intervals(d.nominal), nm)
    lines.append("")
    lines += causes_lines(d.first_round, kind=report.kind, shown=shown, sought=_sought(report))
    lines.append("")
    if d.steps:
        lines.append(f"Extended model: {' + '.join(s.label for s in d.steps)}; chi2/dof = {d.reduced_chi2(d.final):.3g}")
    else:
        lines.append("Extended model: none needed (no cause is significant at any joint or body; the nominal model "
                     "explains the data to the noise)")
    lines += parameter_lines(reported_values(d.final, report), reported_intervals(d.final), nm)
    lines += on_bound_lines(d.on_bounds, name=nm)
    ruled = ruled_out_lines(d.ruled_out(), name=nm)
    if ruled:
        lines += [""] + ruled
    lines += ambiguity_lines(d.ambiguities)
    lines.append("")
    if val is None:
        lines.append("Validation in the MuJoCo rig: none (no held-out data)")
    else:
        replayed = list(range(len(report.run_ids))) if report.held_out_periods else list(report.held_out)
        labels = ([f"{r} (later)" for r in report.run_ids] if report.held_out_periods else held_ids)
        rows = []
        for label, k, (_, nom, ext, _, right) in zip(labels, replayed, val.per_run):
            omega, amp = report.settings[k][:2] if report.settings else (math.nan, math.nan)
            rows.append(ValidationRow(label, omega, amp, True, _cell(nom), _cell(ext), _cell(right)))
        what = "position" if N == 1 else "every joint's twist"
        lines += validation_lines(
            rows, measure=f"relative RMS error of {what}, harmonics 1..{val.band} of the period average",
            drive=kind.drive_symbol,
            summary=f"nominal {_cell(val.nominal_error)}, extended {_cell(val.extended_error)}, a right model "
                    f"{_cell(val.expected_error)} (relative){_right_parts(val)}; gain {sig_or(val.gain, NO_GAIN)}",
            statement=("validation" if report.held_out_periods else "generalisation",
                       generalisation_text(report.generalisation, report.kind)),
            failures=[failures_text(val.failures)] if val.failures else [])
    lines += notes_lines(all_notes)
    return "\n".join(lines)


def train_report_json(report: TrainReport, *, source: str = "", notes: Sequence[str] = (),
                      input_sha256: str = "") -> dict:
    """The train's diagnosis as the one diagnosis document (:mod:`present.diagnosis_json`; SI,
    parameter names carry their units, a slide's in N, m, kg)."""
    from jointrig.studies.holdout import HELD_OUT_PERIODS, HELD_OUT_RUNS

    d, v = report.diagnosis, report.validation
    nm = report.kind.name
    ids = report.run_ids
    if report.held_out_periods:  # each run's later periods
        held_ids, fit_ids = [f"{r} (later periods)" for r in ids], [f"{r} (earlier periods)" for r in ids]
        replayed = list(range(len(ids)))
    else:
        held_ids, fit_ids = [ids[i] for i in report.held_out], [r for i, r in enumerate(ids) if i not in report.held_out]
        replayed = list(report.held_out)
    per_run = []
    if v is not None:
        for label, k, (_, nom, ext, floor, right) in zip(held_ids, replayed, v.per_run):
            omega, amp = report.settings[k][:2] if report.settings else (math.nan, math.nan)
            per_run.append(RunJson(label, True, omega, amp, nom, ext, floor, right_model_error=right))
    r = v.right if v is not None else None
    right = None if r is None else {
        "error": r.relative, "bound": r.bound, "noise": r.noise, "propagated": r.propagated, "method": r.method,
        "rig": r.rig, "dof": r.dof, "estimate_dof": r.estimate_dof, "alpha": r.alpha, "directions": r.directions,
        "draws": r.draws,
        "method_unmeasured": bias_unmeasured_text(r.unmeasured) if r.unmeasured is not None else ""}
    validation = ValidationJson(
        HELD_OUT_PERIODS if report.held_out_periods else HELD_OUT_RUNS, generalisation_text(report.generalisation, report.kind),
        generalisation_text(report.generalisation, report.kind),
        f"relative RMS error of every joint's twist (a single body: its position), harmonics 1..{v.band if v else 0} "
        f"of the period average, over the held-out data: sqrt(sum |sim - meas|^2 / sum |meas|^2)", "1",
        v.nominal_error if v else math.nan, v.extended_error if v else math.nan, v.noise_floor if v else math.nan,
        v.gain if v else math.nan, tuple(per_run), failures_text(v.failures) if v else "no held-out run", right)
    units = "SI; parameter names carry their units" + report.kind.units_note
    return DiagnosisJson(
        source=source, input_sha256=input_sha256, units=units, kind=report.kind,
        n_bodies=d.nominal.spec.n_flywheels, form=report.form, model=report.model_path, verdict=report.verdict,
        band_harmonics=d.n_harmonics, fit_runs=tuple(fit_ids), held_out_runs=tuple(held_ids),
        noise_std_per_sample={report.kind.channel(k): x for k, x in d.noise_std.items()},
        nominal=FitJson.of(d.nominal, nm, _taken(report)), causes=tuple(d.first_round), steps=tuple(d.steps),
        adopted=tuple(s.label for s in d.steps) if report.adopted else (), extended=FitJson.of(d.final, nm, _taken(report)),
        ambiguities=tuple(d.ambiguities),
        as_written={nm(w.name): w.as_json() for w in _written(report)},
        validation=validation, notes=tuple(_notes(notes, report)),
        plausibility=_plausibility(report),
        misfit_character=character_json(report.misfit) if report.misfit is not None else None,
        misfit_surface=surface_json(report.misfit) if report.misfit is not None else None,
        next_measurements=_measurements(report.misfit) if report.misfit is not None else (),
        fidelity=fidelity_json(d.fidelity, fit_ids),
        ruled_out=tuple({"label": s.label, "effect": s.effect, "place": s.as_json()["place"],
                         "magnitude_name": nm(s.magnitude[0]), "limit": lim, "std_error": s.magnitude[2],
                         "detection_probability": DETECTION_POWER} for s, lim in d.ruled_out()),
        preloads=tuple({"joint": j, "mean": q, "std_error": se, "per_run": list(by_run),
                        "unit": report.kind.drive_unit}
                       for j, q, se, by_run in report.preloads),
        on_bounds=tuple(d.on_bounds)).as_json()


from jointrig.identify.causes import DETECTION_POWER  # noqa: E402  (light: no rig)


def fidelity_json(fid, fit_ids: Sequence[str] = ()) -> dict:
    """The fidelity every model's weights carried, for the JSON (:data:`FIDELITY_KEYS`);
    ``fit_ids``: the fitted runs' labels (a run whose replay did not settle is named by it)."""
    from jointrig.identify.chain_diagnose import BalanceFidelity

    if isinstance(fid, BalanceFidelity):
        return {"how": "measured", "relative_misfit": fid.relative, "replayed_model": fid.model,
                "fixed_runs": [_run_label(k, fit_ids) for k in fid.unmeasured],
                "statement": fidelity_statement(fid, fit_ids)}
    return {"how": "fixed", "relative_misfit": None, "replayed_model": None, "fixed_runs": [],
            "statement": fidelity_statement(fid)}


def _run_label(k: int, ids: Sequence[str]) -> str:
    return str(ids[k]) if k < len(ids) else str(k)


def fidelity_statement(fid, fit_ids: Sequence[str] = ()) -> str:
    """The fidelity in words: measured on the replay of a model (and how large), or fixed."""
    from jointrig.identify.chain_diagnose import BalanceFidelity

    if isinstance(fid, BalanceFidelity):
        fixed = ""
        if fid.unmeasured:
            runs = ", ".join(_run_label(k, fit_ids) for k in fid.unmeasured)
            fixed = (f"; the replay of run(s) {runs} reached no periodic steady state (the rig steps at a fixed step: a "
                     f"joint stuck most of the period creeps under its friction constraint, a damping that jumps at "
                     f"contact may never settle): their rows take the largest misfit a replayed run shows at that "
                     f"harmonic relative to its largest balanced torque")
        return (f"measured: {fid.model} replayed in the rig under each fitted run's drive, noise-free, and balanced "
                f"as the runs are, misses {fid.relative:.2g} of the balanced torque (RMS); each row's variance adds "
                f"that run's and harmonic's share, for every model compared{fixed}")
    return f"fixed at {fid:g} of each run's largest balanced torque"


def train_figure(report: TrainReport) -> str:
    """SVG: per held-out run, over one period, what the first cause found acts on (its joint's
    twist, or the body's position for a law to ground): measured (period average), nominal and
    extended model in the rig; below each, where each model departs from the measurement (on the
    harmonics the validation compares, model minus measurement: the extended model's departure
    at the noise, the nominal's the misfit the cause removes). Empty without a cause or without
    simulated runs."""
    from jointrig.studies.chain_validate import departure, found_motion, train_setting

    from . import svg

    d, v = report.diagnosis, report.validation
    if not d.steps or v is None or not v.records:
        return ""
    step = d.steps[0]
    unit = report.kind.unit
    panels, departures = [], []
    for meas, nom, ext in v.records:
        P, N = meas.n_periods, meas.samples_per_period
        what, x = found_motion(meas, step)
        _, amp, _ = train_setting(meas)
        run = f"{meas.omega_rad_s:.4g} rad/s, {amp:.4g} {report.kind.drive_unit}"
        p = svg.Panel(f"{run}: {what}", "t [s]", f"about its mean [{unit}]")
        q = svg.Panel(f"{run}: model minus measurement", "t [s]", f"departure [m{unit}]")
        t = meas.time_s[:N] - meas.time_s[0]
        xm = x.reshape(P, N).mean(axis=0)
        # each about its own mean: the comparison leaves the mean out (a sensor's zero is arbitrary)
        p.line(t, xm - xm.mean(), color=svg.COLORS["black"], width=2.2, opacity=0.5, label="measured")
        for name, sim, style in (("nominal", nom, dict(color=svg.COLORS["red"], dash="5 3")),
                                 ("extended", ext, dict(color=svg.COLORS["blue"]))):
            xs = found_motion(sim, step)[1]
            p.line(sim.time_s - sim.time_s[0], xs - xs.mean(), width=1.2, label=name, **style)
            q.line(t, 1e3 * departure(meas, sim, step, v.band), width=1.2, label=name, **style)
        panels.append(p)
        departures.append(q)
    panels[0].legend = departures[0].legend = True
    cols = min(3, len(panels))
    ordered = []
    for k in range(0, len(panels), cols):  # a row of runs, then the row of their departures
        ordered += panels[k:k + cols] + departures[k:k + cols]
    return svg.figure(ordered, cols=cols, panel_width=400, panel_height=260, title=f"held-out data: {step.label}")


def write_train_html(path, report: TrainReport, text: str, *, title: str, source: str = "",
                     notes: Sequence[str] = (), input_sha256: str = "", cards: Sequence = ()):
    """A self-contained HTML page of a train's diagnosis, written atomically: the verdict, what
    the sensors read at rest, your model as written, the causes found, the held-out runs as a figure, the parameters; the
    candidates, the notes on the data and the console text folded below."""
    import html
    from pathlib import Path

    from jointrig.files import write_atomic

    from .page import card_section, page_top, row, surface_figure, svg_figure_html, table

    d = report.diagnosis
    nm = report.kind.name
    fit = report.adopted_fit
    written = _written(report)
    parts = page_top(title, report.verdict, plain_train_verdict(report), input_sha256)
    final = reported_values(d.final, report)
    readings = offset_readings(report)
    if readings:  # what the sensors read at rest, on the first screen as in the text's first lines
        parts.append("<h2>What your sensors read at rest</h2><ul>"
                     + "".join(f"<li>{html.escape(r)}</li>" for r in readings) + "</ul>")
    if d.steps:
        parts.append("<h2>What the data show</h2>" if report.adopted else
                     "<h2>The best extension, not adopted (see the verdict)</h2>")
        parts.append(table(["cause", "size", "unit"], [
            row([s.label, (with_se(*final.get(s.magnitude[0], s.magnitude[1:])), "num"), unit_of(nm(s.magnitude[0]))])
            for s in d.steps]))
    if written:
        parts.append("<h2>Your model as written</h2>" if not written[0].provisional else
                     "<h2>Your model as written (provisional: no model explains the data, so the fit these figures "
                     "come from may be wrong too)</h2>")
        parts.append(table(["parameter", "written", "the data", "unit", ""], [
            row([nm(w.name), (f"{w.written:.6g}", "num"), (with_se(w.data, w.std_error), "num"), unit_of(nm(w.name)),
                  (("may differ: " if w.provisional else "differs: ") + w.change) if w.differs else "agrees"],
                "adopted" if w.differs else "")
            for w in written]))
    m = report.misfit
    if m is not None:
        character, surface = misfit_texts(m)
        parts.append("<h2>What the misfit looks like</h2>")
        parts.append(f"<p>Where: {html.escape(places_text(m))}.</p><p>{html.escape(character[:1].upper() + character[1:])}."
                     f"</p><p>{html.escape(surface[:1].upper() + surface[1:])}.</p>")
        if m.next_measurements:
            parts.append("<p>Measurements that would tell more:</p><ul>"
                         + "".join(f"<li>{html.escape(t)}</li>" for t in _measurements(m)) + "</ul>")
        parts.append(svg_figure_html(f"The nominal model's residual {words_of(m).torque} at {m.where} as a "
                                     f"restoring-force surface, over every run's measured motion",
                                     surface_figure(m.surface, m.samples, words_of(m))))
    image = train_figure(report)
    if image:
        parts.append(svg_figure_html(f"Held-out data ({generalisation_text(report.generalisation, report.kind)}): measured, and simulated in the rig "
                                     f"with the nominal and the extended model", image))
    parts.append(f"<h2>{'Extended' if report.adopted else 'Nominal'} model</h2>")
    intervals = reported_intervals(fit)
    parts.append(table(["parameter", "value ± standard error", "unit", "95% interval ±"], [
        row([nm(n), (with_se(x, se), "num"), unit_of(nm(n)), (interval_text(*intervals.get(n, (math.nan, math.inf))), "num")])
        for n, (x, se) in reported_values(fit, report).items()]))
    if report.adopted:  # a value on an end of its search, under the table that shows it
        parts += [f"<p class='note'>{html.escape(line.strip())}.</p>" for line in on_bound_lines(d.on_bounds, name=nm)]
    for card, png in cards:  # (card, its PNG) per place, with --card: folded, one per joint
        section = card_section(card, png)
        parts.append(f"<details class='section'><summary>Joint card of {html.escape(card.place)}</summary>"
                     + "".join(section[1:]) + "</details>")
    parts.append("<details class='section'><summary>Every candidate, scored on the nominal model</summary>")
    parts.append(table(["candidate", "BIC score", "p", "size", "note"], [
        row([s.label, (f"{s.score:.1f}", "num"), (f"{s.p_value:.2g}", "num"),
              f"{quantity_of(nm(s.magnitude[0]))} = {with_se(s.magnitude[1], s.magnitude[2])} {unit_of(nm(s.magnitude[0]))}",
              rejection_text(s.note, report.kind) if s.note else ""]) for s in d.first_round]))
    parts.append("</details>")
    all_notes = _notes(notes, report)
    if all_notes:
        parts.append(f"<details class='section'><summary>Notes on the data ({len(all_notes)})</summary><ul>"
                     + "".join(f"<li class='note'>{html.escape(n)}</li>" for n in all_notes) + "</ul></details>")
    parts.append(f"<details><summary>The same report as console text</summary><pre>{html.escape(text)}</pre></details>")
    parts.append("</body></html>")
    page = "".join(parts)
    path = Path(path)
    write_atomic(path, lambda tmp: tmp.write_text(page, encoding="utf-8"))
    return path
