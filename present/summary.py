"""The answer of a diagnosis in plain words: what a test engineer reads first (pure).

The report's first screen and the text's second line come from here: the verdict as a sentence,
each adopted cause with its size and what it is, the parameters of the model as given beside the
data's, and what to measure next. Figures that need a word of explanation (chi2/dof, the gain,
the noise floor) carry it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jointrig.identify.causes import CATALOGUE
from jointrig.studies.validate import DiagnosisReport

from .formatting import quantity_of, unit_of, with_se

__all__ = ["NO_GAIN", "plain_verdict", "ParameterRow", "parameter_rows", "adopted_causes", "next_steps", "WrittenRow",
           "written_rows", "compare_written", "wrong_sentence", "offset_reading", "steps_after"]

_DESCRIPTION = {c.name: c.description for c in CATALOGUE}
#: The gain's cell when a model has no steady state in a held-out run.
NO_GAIN = "not computed (a model has no steady state in a held-out run)"


def _fits(report: DiagnosisReport) -> str:
    d = report.diagnosis
    f = d.extended if report.adopted else d.nominal
    c2 = f.chi2 / max(f.dof, 1)
    return f"the model fits the runs to their noise (chi2/dof {c2:.2g}: about 1 when only noise is left)"


@dataclass(frozen=True)
class WrittenRow:
    """A parameter of the user's model as written beside what the data say (the adopted model's
    value, else the nominal fit's), and whether the two differ by more than two standard errors."""

    name: str
    quantity: str
    unit: str
    written: float
    data: float
    std_error: float
    differs: bool

    @property
    def change(self) -> str:
        """The data's value against the written one, in words ("21% lower")."""
        if self.written == 0:
            return f"{self.data:.3g} instead of 0"
        rel = self.data / self.written - 1
        return f"{abs(rel):.0%} {'higher' if rel > 0 else 'lower'}" if abs(rel) < 10 else f"{self.data / self.written:.3g} times"

    def as_json(self) -> dict:
        return {"written": self.written, "data": self.data, "std_error": self.std_error, "differs": self.differs,
                "change": self.change}


def written_rows(report: DiagnosisReport) -> tuple[WrittenRow, ...]:
    """Each parameter of the user's model (``jointrig diagnose --model``) as written, beside
    what the data say; empty without a model."""
    d = report.diagnosis
    return compare_written(report.written, d.extended if report.adopted else d.nominal)


def compare_written(written, fit) -> tuple[WrittenRow, ...]:
    """``written`` ((name, value) pairs of the user's model) beside a fit's values and standard
    errors (any :class:`identify.estimates.Estimates`); names the fit lacks are left out."""
    values = fit.as_dict()
    out = []
    for name, w in written:
        if name not in values:
            continue
        v, se = values[name], fit.std_error(name)
        differs = bool(math.isfinite(se) and abs(v - w) > 2 * se)
        out.append(WrittenRow(name, quantity_of(name), unit_of(name), w, v, se, differs))
    return tuple(out)


def _wrong(report: DiagnosisReport) -> str:
    return wrong_sentence(written_rows(report))


def wrong_sentence(rows, name=lambda n: n) -> str:
    """The parameters of the user's model the data contradict, as a sentence ("" if none);
    ``name`` gives each parameter's name as the user's bench has it."""
    rows = [r for r in rows if r.differs]
    if not rows:
        return ""
    return ("As written, your model has " + "; ".join(
        f"{quantity_of(name(r.name))} = {r.written:.6g}{' ' + unit_of(name(r.name)) if unit_of(name(r.name)) else ''}, "
        f"which the data put at "
        f"{with_se(r.data, r.std_error)} ({r.change})" for r in rows) + ". ")


def plain_verdict(report: DiagnosisReport) -> str:
    """The verdict as one or two sentences without jargon (the parameters of the user's model
    that the data contradict first, when one was given)."""
    return _wrong(report) + _verdict_sentence(report)


def _verdict_sentence(report: DiagnosisReport) -> str:
    v = report.verdict
    d = report.diagnosis
    floor = report.noise_floor_rad
    ratio = report.validation_rms("extended" if report.adopted else "nominal") / floor if floor > 0 else math.nan
    held = ("runs it was not fitted on" if report.validation_kind == "held_out_runs"
            else "later periods of the runs, which it was not fitted on")
    if v.verdict == "no_misfit":
        return (f"Your model explains the data: {_fits(report)}, and simulated in the rig it predicts the "
                f"{held} to {ratio:.2g} times the noise floor. No cause needs to be added.")
    if v.verdict == "explained":
        causes = "; ".join(f"{a.what} ({a.quantity} {a.value})" for a in adopted_causes(report))
        gain = (f"{report.gain:.3g} times better than without" if math.isfinite(report.gain)
                else "where the model without it reaches no steady state")
        return (f"Your model misses {causes}. With it, {_fits(report)}, and simulated in the rig it predicts the "
                f"{held} {gain} (at {ratio:.2g} times the noise floor).")
    tried = " + ".join(d.effects)
    return ("Your model does not explain the data, and no known cause does"
            + (f": the best candidate ({tried}) was rejected" if tried else "")
            + ". Nothing is added to the model; what the misfit looks like and what to measure next are below.")


@dataclass(frozen=True)
class AdoptedCause:
    """An adopted cause: its name, what it is in words, the size parameter and its value."""

    name: str
    what: str
    quantity: str
    value: str


def adopted_causes(report: DiagnosisReport) -> tuple[AdoptedCause, ...]:
    d = report.diagnosis
    ext = d.extended
    params = ext.effect_parameters()
    out = []
    for step in d.steps:
        if step.effect not in report.adopted:
            continue
        name = step.magnitude[0]
        value = params.get(name, step.magnitude[1])
        unit = unit_of(name)
        out.append(AdoptedCause(step.effect, _DESCRIPTION.get(step.effect, step.effect).split(":")[0],
                                quantity_of(name), f"{with_se(value, ext.std_error(name))}{' ' + unit if unit else ''}"))
    return tuple(out)


@dataclass(frozen=True)
class ParameterRow:
    """A parameter of the model as given (fitted to the data) beside the extended model's, and
    whether the two differ by more than twice their combined standard error."""

    quantity: str
    unit: str
    as_given: str
    with_causes: str
    differs: bool


def parameter_rows(report: DiagnosisReport) -> tuple[ParameterRow, ...]:
    """The nominal model's parameters (the structure as given, fitted to the data) and, when a
    cause is adopted, the same parameters in the extended model; then the causes' own."""
    d = report.diagnosis
    nom, ext = d.nominal, d.extended
    extended = bool(report.adopted)
    out = []
    for name, v in nom.as_dict().items():
        se = nom.std_error(name)
        if extended and name in ext.names:
            w, se2 = ext.as_dict()[name], ext.std_error(name)
            both = math.hypot(se, se2) if math.isfinite(se) and math.isfinite(se2) else math.nan
            out.append(ParameterRow(quantity_of(name), unit_of(name), with_se(v, se), with_se(w, se2),
                                    bool(abs(v - w) > 2 * both)))
        else:
            out.append(ParameterRow(quantity_of(name), unit_of(name), with_se(v, se), "", False))
    if extended:
        for name, w in ext.effect_parameters().items():
            if name not in nom.names:
                out.append(ParameterRow(quantity_of(name), unit_of(name), "-", with_se(w, ext.std_error(name)), True))
    return tuple(out)


#: The largest zero offset of the relative angle read as a sensor's (rad, about 11 deg): beyond
#: it an even stiffness is taken as the joint's.
MAX_ZERO_OFFSET_RAD = 0.2


def offset_reading(report: DiagnosisReport) -> str:
    """An adopted even stiffness ``a phi^2`` beside a cubic ``gamma phi^3`` is, to first order,
    what a constant zero offset ``delta = -a / (3 gamma)`` of the relative angle makes of the
    cubic: the data cannot tell the two apart, and an encoder's zero is the likelier. The
    reading in words, or "" (pure)."""
    if "asymmetric_stiffness" not in report.diagnosis.effects:  # adopted, or the rejected best candidate's
        return ""
    p = report.diagnosis.extended.as_dict()
    a, gamma = p.get("a_Nm_per_rad2"), p.get("gamma_Nm_per_rad3")
    if not a or not gamma or gamma <= 0:
        return ""
    delta = -a / (3 * gamma)  # gamma (phi - delta)^3 = gamma phi^3 - 3 gamma delta phi^2 + ...
    if abs(delta) > MAX_ZERO_OFFSET_RAD:
        return ""
    return (f"the even stiffness a = {a:.4g} N m/rad^2 is exactly what a zero offset of the relative angle of "
            f"-a / (3 gamma) = {delta:.3g} rad ({math.degrees(delta):.2g} deg) makes of the cubic gamma = {gamma:.4g} "
            f"N m/rad^3: the data cannot tell the two apart. Check the angle sensors' zero; if the joint is "
            f"symmetric, subtract {delta:.3g} rad from the relative angle (phi1) and run the diagnosis again")


def next_steps(report: DiagnosisReport) -> tuple[str, ...]:
    """What to measure or do next, in words."""
    d = report.diagnosis
    offset = offset_reading(report)
    if report.verdict.verdict == "unexplained":
        return tuple(d.plausibility) + ((offset,) if offset else ()) + tuple(report.next_measurements)
    return tuple(d.plausibility) + ((offset,) if offset else ()) + steps_after(
        report.verdict.verdict, d.ambiguous, report.validation_kind != "held_out_runs")


def steps_after(verdict: str, ambiguities, later_periods_only: bool) -> tuple[str, ...]:
    """What to do next after a diagnosis that is not unexplained, on every bench: tell apart what
    the data cannot, test on another excitation when only later periods were held out, and put
    an adopted cause into the model."""
    out = [f"{a.effects[0]} and {a.effects[1]} explain the same part of the data; to tell them apart: {a.excitation}"
           for a in ambiguities]
    if later_periods_only:
        out.append("runs at other drive levels or frequencies: the model was checked only on later periods of the "
                   "same runs")
    if verdict == "explained":
        out.append("put the adopted cause into your model (--mjcf writes the extended model as MuJoCo XML) and "
                   "check it at the operating point that matters to you")
    return tuple(out)
