"""What a drive train's diagnosis says, as text and JSON (pure): ``jointrig diagnose`` on a
train's file, and the demo ``jointrig diagnose-chain``.

The text opens on the verdict and, with the user's model (``--model``), on each parameter as
written beside what the data say; then the place and size of every cause found, the candidates
ranked, and the held-out runs' error in the rig.
"""

from __future__ import annotations

from typing import Sequence

from jointrig.studies.chain_validate import TrainReport

from .formatting import quantity_of, sig, sig_or, unit_of, with_se
from .summary import compare_written

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
    places = ([f"{n_joint} causes at {N - 1} joint(s)"] if N > 1 else []) + [
        f"bearing drag at {N} {'bodies' if N > 1 else 'body'}", f"{n_ground} laws to ground"]
    lines = [f"  nominal model: chi2/dof = {d.nominal.chi2 / d.nominal.dof:.3g} (about 1 when only noise is left)",
             f"  candidates ({len(d.first_round)}: {', '.join(places)}), best first:"]
    for s in d.first_round[:n_shown]:
        lines.append(f"    {s.label:40s} score {s.score:10.1f}  p = {s.p_value:.2g}  {quantity_of(s.magnitude[0])} = "
                     f"{with_se(s.magnitude[1], s.magnitude[2])} {unit_of(s.magnitude[0])}"
                     + (f"  [{s.note}]" if s.note else ""))
    if not d.steps:
        lines.append("  nothing significant: no catalogued cause at any joint or bearing")
    final = _values(d.final)
    for s in d.steps:  # at their size in the extended model (refined beside the other causes)
        name = s.magnitude[0]
        value, se = final.get(name, s.magnitude[1:])
        lines.append(f"  FOUND: {s.label}: {quantity_of(name)} = {with_se(value, se)} {unit_of(name)}")
    if d.steps:
        lines.append(f"  extended model: chi2/dof = {d.final.chi2 / d.final.dof:.3g}")
    for a in d.ambiguities:
        lines.append(f"  AMBIGUOUS: {a.candidates[0]} or {a.candidates[1]}: {a.explanation}")
    if v is not None:
        if v.note:
            lines.append(f"  held-out runs: {v.note}")
        else:
            lines.append(f"  held-out runs ({len(report.held_out)}): twist error nominal {sig(v.nominal_error)}, "
                         f"extended {sig(v.extended_error)} (noise floor {sig(v.noise_floor, 2)}): gain "
                         f"{sig_or(v.gain, 'not computed')}")
    return lines


def format_train_report(report: TrainReport, *, source: str = "", notes: Sequence[str] = ()) -> str:
    d, v = report.diagnosis, report.verdict
    fit = report.adopted_fit
    N = d.nominal.spec.n_flywheels
    fit_ids = [r for i, r in enumerate(report.run_ids) if i not in report.held_out]
    held_ids = [report.run_ids[i] for i in report.held_out]
    lines = [f"VERDICT: {v.verdict.upper().replace('_', ' ')}: {v.reason}"]
    written = compare_written(report.written, fit)
    if written:
        lines.append(f"  Your model as written ({report.model_path}) against the data (differs: more than 2 standard "
                     f"errors apart):")
        lines += [f"    {w.name:34s} written {w.written:<12.6g} data {with_se(w.data, w.std_error):>22s} "
                  f"{w.unit:12s} {'DIFFERS, ' + w.change if w.differs else 'agrees'}" for w in written]
    lines += ["", f"Diagnosis of {source or 'the runs'}: a train of {N} bodies, {len(report.run_ids)} runs, harmonics "
                  f"1..{d.n_harmonics}",
              f"  fit on runs {', '.join(fit_ids)}; held out for validation: {', '.join(held_ids)} "
              f"({report.generalisation})",
              "  noise per sample (from period-to-period variation): "
              + ", ".join(f"{k} {sig(x, 2)} {'N m' if k.startswith('torque') else 'rad'}"
                          for k, x in d.noise_std.items())]
    lines += format_chain_lines(report)
    lines += ["", f"{'Extended' if report.adopted else 'Nominal'} model's parameters (+- standard error, SI):"]
    lines += [f"  {n:34s} {with_se(x, se):>24s} {unit_of(n)}" for n, (x, se) in _values(fit).items()]
    notes = list(notes) + list(report.notes)
    if notes:
        lines += ["", f"Notes on the data ({len(notes)}):"] + [f"  - {n}" for n in notes]
    return "\n".join(lines)


def train_report_json(report: TrainReport, *, source: str = "", notes: Sequence[str] = (),
                      input_sha256: str = "") -> dict:
    """The train's diagnosis as JSON (SI; parameter names carry their units)."""
    d = report.diagnosis
    return {"source": source, "input_sha256": input_sha256, "bench": "train",
            "n_bodies": d.nominal.spec.n_flywheels,
            "verdict": {"verdict": report.verdict.verdict, "reason": report.verdict.reason},
            "runs": list(report.run_ids), "held_out": [report.run_ids[i] for i in report.held_out],
            "generalisation": report.generalisation, **d.as_json(),
            "validation": report.validation.as_json() if report.validation is not None else None,
            "as_written": {w.name: w.as_json() for w in compare_written(report.written, report.adopted_fit)},
            "model": report.model_path, "notes": list(notes) + list(report.notes),
            "units": "SI; parameter names carry their units"}
