"""The sections of the diagnosis's text report, one layout for every bench (pure).

Every bench's report (``present.train_report.format_train_report``: two flywheels, a train, a
single axis) prints these sections in these columns:
the verdict and what to do next; the data; the nominal model; the causes ranked by evidence;
the extended model; the validation in the rig; the notes on the data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

from jointrig.identify.causes import Ambiguity, CauseScore
from jointrig.vocab.params import HINGE, Coordinate

from .formatting import interval_text, quantity_of, sig, unit_of, with_se
from .notes import rejection_text, separation_text, verdict_text
from .summary import WRITTEN_SE, WRITTEN_SHARE

__all__ = ["ValidationRow", "head_lines", "parameter_lines", "causes_lines", "ambiguity_lines", "validation_lines",
           "on_bound_lines", "notes_lines"]


def head_lines(verdict, words: str, steps: Sequence[str], *, written: Sequence = (), model: str = "",
               name: Callable[[str], str] = str, misfit: Sequence[str] = ()) -> list[str]:
    """The answer first: the verdict with its figures, in words; the user's model as written
    against the data (``written``: ``present.summary.WrittenRow``); what the misfit looks like
    (``misfit``, when unexplained); and what to do next."""
    lines = [f"VERDICT: {verdict.verdict.upper().replace('_', ' ')}: {verdict_text(verdict)}", f"  In words: {words}"]
    if written:
        provisional = any(w.provisional for w in written)
        lines.append(f"  Your model as written{f' ({model})' if model else ''} against the data (differs: more than "
                     f"{WRITTEN_SE:g} standard errors and {WRITTEN_SHARE:.0%} apart" + ("; PROVISIONAL: no model explains the data, so the fit these figures "
                                                   "come from may be wrong too" if provisional else "") + "):")
        lines += [f"    {quantity_of(name(w.name)):28s} written {w.written:<12.6g} data "
                  f"{with_se(w.data, w.std_error):>22s} {unit_of(name(w.name)):12s} "
                  f"{('may differ, ' if w.provisional else 'DIFFERS, ') + w.change if w.differs else 'agrees'}"
                  for w in written]
    lines += [f"  {m}" for m in misfit]
    if steps:
        lines.append("  What to do next" + (" (measurements that would tell more):" if verdict.verdict == "unexplained"
                                             else ":"))
        lines += [f"    - {s}" for s in steps]
    return lines


def parameter_lines(values: Mapping[str, tuple[float, float]], intervals: Mapping[str, tuple[float, float]],
                    name: Callable[[str], str] = str) -> list[str]:
    """A header, then one line per parameter: its quantity, value +- standard error, unit
    (``name``: the parameter's name on the user's bench) and its 95% interval (``intervals``:
    name -> half width, degrees of freedom of the error)."""
    out = [f"  {'':28s} {'value ± standard error':>24s} {'unit':14s} 95% interval (the error's degrees of freedom)"]
    for n, (v, se) in values.items():
        half, dof = intervals.get(n, (math.nan, math.inf))
        out.append(f"  {quantity_of(name(n)):28s} {with_se(v, se):>24s} {unit_of(name(n)):14s} {interval_text(half, dof)}")
    return out


def _where(signature: dict) -> str:
    if not signature:
        return "-"
    out = "/".join(f"{signature.get(k, 0.0):.0%}" for k in ("mean", "fundamental", "even", "odd>=3"))
    if signature.get("dissipative") is not None:
        out += f"; {signature['dissipative']:.2f}"
    return out


def causes_lines(scores: Sequence[CauseScore], *, kind: Coordinate = HINGE, shown: int = 0,
                 sought: str = "") -> list[str]:
    """The causes ranked by evidence, as a table, named for a bench of ``kind``: every one, or the
    significant ones and the best ``shown`` (the rest counted; all of them are in the JSON), each
    rejected one with why (:func:`present.notes.rejection_text`); ``sought``: where they were sought."""
    keep = [i for i, s in enumerate(scores) if not shown or i < shown or s.significant]
    width = max([22] + [len(scores[i].label) for i in keep])
    lines = [f"Causes ranked by evidence ({f'{sought}; ' if sought else ''}score = drop in chi2 - n_params "
             f"ln(n_rows); significant: p < alpha / n_causes, alpha = 1e-3 unless --alpha):",
             f"  {'rank':4s} {'effect':{width}s} {'score':>12s} {'d_chi2':>12s} {'q':>2s} {'p':>9s} {'sig':>4s}  "
             f"magnitude; where the improvement is (mean/fund./even/odd>=3); dissipative share"]
    for i in keep:
        c = scores[i]
        q = kind.name(c.magnitude[0])
        mag = f"{quantity_of(q)} = {with_se(c.magnitude[1], c.magnitude[2])} {unit_of(q)}"
        lines.append(f"  {i + 1:<4d} {c.label:{width}s} {c.score:12.4g} {c.delta_chi2:12.4g} {c.n_params:2d} "
                     f"{c.p_value:9.2g} {'yes' if c.significant else 'no':>4s}  {mag}; {_where(c.signature)}"
                     + (f"  [{rejection_text(c.note, kind)}]" if c.note else ""))
    if len(keep) < len(scores):
        lines.append(f"  ... and {len(scores) - len(keep)} more, none significant (every one is in --json)")
    return lines


def on_bound_lines(on_bounds: Sequence[tuple], *, name: Callable[[str], str] = str) -> list[str]:
    """A line for each profiled parameter that ended on an end of its search
    (:attr:`identify.chain_diagnose.ChainDiagnosis.on_bounds`): the value beyond it is not ruled
    out, and its standard error is one-sided."""
    out = []
    for param, side, bound in on_bounds:
        q = name(param)
        at = " ".join(x for x in (sig(bound), unit_of(q)) if x)
        beyond = "smaller" if side == "lower" else "larger"
        out.append(f"  {quantity_of(q)} lies on the {side} end of its search ({at}): these runs do not rule out a "
                   f"{beyond} value, and its standard error is one-sided")
    return out


def ruled_out_lines(limits: Sequence[tuple], *, name: Callable[[str], str] = str, shown: int = 8) -> list[str]:
    """What the runs rule out: for each cause not adopted (``(score, limit)`` pairs,
    :meth:`identify.chain_diagnose.ChainDiagnosis.ruled_out`), the size above which these runs
    would have found it, in the order the causes were ranked (the first ``shown``)."""
    from jointrig.identify.causes import DETECTION_POWER

    if not limits:
        return []
    out = [f"What these runs rule out (a cause this size or larger is found {DETECTION_POWER:.0%} of the time; "
           f"below it these runs could not see it):"]
    for s, lim in list(limits)[:shown]:
        q = name(s.magnitude[0])
        out.append(f"  {s.label}: {quantity_of(q)} above {lim:.2g} {unit_of(q)}".rstrip())
    if len(limits) > shown:
        out.append(f"  ... and {len(limits) - shown} more (every one is in --json)")
    return out


def ambiguity_lines(ambiguities: Sequence[Ambiguity]) -> list[str]:
    return [f"  CANNOT TELL APART: {a.effects[0]} and {a.effects[1]} explain the same part of the data (neither is "
            f"significant given the other). To separate them: {separation_text(a)}." for a in ambiguities]


@dataclass(frozen=True)
class ValidationRow:
    """One run replayed in the rig, its cells as printed (an error, or why there is none)."""

    run: str
    omega_rad_s: float
    drive: float
    held_out: bool
    nominal: str
    extended: str
    right: str


def validation_lines(rows: Sequence[ValidationRow], *, measure: str, drive: str, summary: str,
                     statement: tuple[str, str], failures: Sequence[str] = ()) -> list[str]:
    """The replay of the runs in the rig: one row per run (each model's error and a right model's),
    the held-out summary (errors, what a right model misses, gain), models without a steady state,
    and what the held-out data test (label, words)."""
    w = max([6] + [len(r.run) for r in rows])
    lines = [f"Validation in the MuJoCo rig under each run's measured drive ({measure}):",
             f"  {'run':>{w}s} {'omega':>8s} {drive:>8s} {'held out':>8s} {'nominal':>10s} {'extended':>10s} "
             f"{'right':>10s}"]
    lines += [f"  {r.run:>{w}s} {r.omega_rad_s:8.4g} {r.drive:8.4g} {'yes' if r.held_out else '':>8s} "
              f"{r.nominal:>10s} {r.extended:>10s} {r.right:>10s}" for r in rows]
    lines.append(f"  held-out runs: {summary}")
    lines += [f"  {f}" for f in failures]
    lines.append(f"  {statement[0]}: {statement[1]}")
    return lines


def notes_lines(notes: Sequence[str]) -> list[str]:
    return ["", "Notes on the data:"] + [f"  note: {n}" for n in notes] if notes else []
