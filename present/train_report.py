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

from jointrig.studies.chain_validate import TrainReport

from jointrig.vocab.params import linear_name

from .formatting import quantity_of, sig, sig_or, unit_of, with_se
from .summary import compare_written, wrong_sentence


def _namer(report: TrainReport):
    """Parameter names as the user's bench has them: a slide's in N and m (vocab.params.linear_name)."""
    return linear_name if report.kind == "slide" else (lambda n: n)


def _words(report: TrainReport, text: str) -> str:
    """A note's parameter names as the user's bench has them."""
    if report.kind != "slide":
        return text
    return re.sub(r"\b\w+_\w+\b", lambda m: linear_name(m.group()), text)


def _channel(report: TrainReport, ch: str) -> str:
    if report.kind == "slide":
        return ch.replace("torque", "force").replace("phi", "x")
    return ch

__all__ = ["format_train_report", "train_report_json", "format_chain_lines"]


def _values(fit) -> dict:
    """Every parameter of a chain fit with its standard error: the linear ones, then the
    profiled (free play, slip angles, zero offsets)."""
    out = {n: (v, fit.std_error(n)) for n, v in fit.as_dict().items()}
    out.update({n: (v, se) for n, v, se in fit.profiled})
    return out


def format_chain_lines(report: TrainReport, n_shown: int = 6) -> list[str]:
    """The diagnosis's figures: the nominal fit, the candidates best first, what was found, the
    extended fit, the ambiguities and the held-out error."""
    d, v = report.diagnosis, report.validation
    N = d.nominal.spec.n_flywheels
    n_joint = sum(1 for s in d.first_round if s.at_joint)
    n_ground = sum(1 for s in d.first_round if s.ground)
    n_drag = len(d.first_round) - n_joint - n_ground
    places = ([f"{n_joint} causes at {N - 1} joint(s)"] if N > 1 else []) + (
        [f"viscous drag at {n_drag} {'bodies' if n_drag > 1 else 'body'}"] if n_drag else []) + (
        [f"{n_ground} laws to ground"] if n_ground else [])
    lines = [f"  nominal model: chi2/dof = {d.nominal.chi2 / d.nominal.dof:.3g} (about 1 when only noise is left)",
             f"  candidates ({len(d.first_round)}: {', '.join(places)}), best first:"]
    nm = _namer(report)
    for s in d.first_round[:n_shown]:
        name = nm(s.magnitude[0])
        lines.append(f"    {s.label:40s} score {s.score:10.1f}  p = {s.p_value:.2g}  {quantity_of(name)} = "
                     f"{with_se(s.magnitude[1], s.magnitude[2])} {unit_of(name)}"
                     + (f"  [{_words(report, s.note)}]" if s.note else ""))
    if not d.steps:
        lines.append("  nothing significant: no catalogued cause at any joint or bearing")
    final = _values(d.final)
    for s in d.steps:  # at their size in the extended model (refined beside the other causes)
        value, se = final.get(s.magnitude[0], s.magnitude[1:])
        name = nm(s.magnitude[0])
        lines.append(f"  FOUND: {s.label}: {quantity_of(name)} = {with_se(value, se)} {unit_of(name)}")
    if d.steps:
        lines.append(f"  extended model: chi2/dof = {d.final.chi2 / d.final.dof:.3g}")
    for a in d.ambiguities:
        lines.append(f"  AMBIGUOUS: {a.candidates[0]} or {a.candidates[1]}: {a.explanation}")
    if v is not None:
        held = "held-out periods" if report.held_out_periods else f"held-out runs ({len(report.held_out)})"
        what = "position" if N == 1 else "twist"
        if v.note and not math.isfinite(v.extended_error):
            lines.append(f"  {held}: {v.note}")
        elif v.note:
            lines.append(f"  {held}: relative {what} error extended {sig(v.extended_error)} (noise floor "
                         f"{sig(v.noise_floor, 2)}); {v.note}")
        else:
            lines.append(f"  {held}: relative {what} error nominal {sig(v.nominal_error)}, extended "
                         f"{sig(v.extended_error)} (noise floor {sig(v.noise_floor, 2)}): gain "
                         f"{sig_or(v.gain, 'not computed')}")
    return lines


def format_train_report(report: TrainReport, *, source: str = "", notes: Sequence[str] = ()) -> str:
    d, v = report.diagnosis, report.verdict
    fit = report.adopted_fit
    N = d.nominal.spec.n_flywheels
    fit_ids = [r for i, r in enumerate(report.run_ids) if i not in report.held_out]
    held_ids = [report.run_ids[i] for i in report.held_out]
    lines = [f"VERDICT: {v.verdict.upper().replace('_', ' ')}: {v.reason}"]
    nm = _namer(report)
    written = compare_written(report.written, fit)
    wrong = wrong_sentence(written, nm)
    if wrong:
        lines.append(f"  In words: {wrong.strip()}")
    if written:
        lines.append(f"  Your model as written ({report.model_path}) against the data (differs: more than 2 standard "
                     f"errors apart):")
        lines += [f"    {nm(w.name):34s} written {w.written:<12.6g} data {with_se(w.data, w.std_error):>22s} "
                  f"{unit_of(nm(w.name)):12s} {'DIFFERS, ' + w.change if w.differs else 'agrees'}" for w in written]
    slide = report.kind == "slide"
    if N == 1:
        what = f"a single body on a {'slide' if slide else 'hinge'}"
    else:
        what = f"{N} bodies on slides" if slide else f"a train of {N} bodies"
    if report.held_out_periods:
        validation = f"  fit on the earlier periods of run(s) {', '.join(report.run_ids)}; held out: {report.generalisation}"
    else:
        validation = (f"  fit on runs {', '.join(fit_ids)}; held out for validation: {', '.join(held_ids)} "
                      f"({report.generalisation})")
    units = ("N", "m") if slide else ("N m", "rad")
    lines += ["", f"Diagnosis of {source or 'the runs'}: {what}, {len(report.run_ids)} run(s), harmonics "
                  f"1..{d.n_harmonics}", validation,
              "  noise per sample (from period-to-period variation): "
              + ", ".join(f"{_channel(report, k)} {sig(x, 2)} {units[0] if k.startswith('torque') else units[1]}"
                          for k, x in d.noise_std.items())]
    lines += format_chain_lines(report)
    lines += ["", f"{'Extended' if report.adopted else 'Nominal'} model's parameters (+- standard error, SI):"]
    lines += [f"  {nm(n):34s} {with_se(x, se):>24s} {unit_of(nm(n))}" for n, (x, se) in _values(fit).items()]
    notes = list(notes) + list(report.notes)
    if notes:
        lines += ["", f"Notes on the data ({len(notes)}):"] + [f"  - {n}" for n in notes]
    return "\n".join(lines)


def train_report_json(report: TrainReport, *, source: str = "", notes: Sequence[str] = (),
                      input_sha256: str = "") -> dict:
    """The train's diagnosis as JSON (SI; parameter names carry their units)."""
    d = report.diagnosis
    nm = _namer(report)
    dj = d.as_json()
    for key in ("nominal", "extended"):
        for sub in ("parameters", "std_errors"):
            if sub in dj[key]:
                dj[key][sub] = {nm(k): v for k, v in dj[key][sub].items()}
    for key in ("candidates_first_round", "found"):
        for c in dj[key]:
            c["magnitude"]["name"] = nm(c["magnitude"]["name"])
    dj["noise_std_per_sample"] = {_channel(report, k): v for k, v in dj["noise_std_per_sample"].items()}
    return {"source": source, "input_sha256": input_sha256, "bench": "train", "kind": report.kind,
            "n_bodies": d.nominal.spec.n_flywheels,
            "verdict": {"verdict": report.verdict.verdict, "reason": report.verdict.reason},
            "runs": list(report.run_ids), "held_out": [report.run_ids[i] for i in report.held_out],
            "generalisation": report.generalisation,
            "validation_kind": "held_out_periods" if report.held_out_periods else "held_out_runs", **dj,
            "validation": report.validation.as_json() if report.validation is not None else None,
            "as_written": {nm(w.name): w.as_json() for w in compare_written(report.written, report.adopted_fit)},
            "model": report.model_path, "notes": list(notes) + list(report.notes),
            "units": "SI; parameter names carry their units" + (" (bodies on slides: N, m, kg)" if report.kind == "slide"
                                                                 else "")}
