"""Pieces of a diagnosis's answer in plain words, for every bench (pure): the user's model as
written beside the data, the parameters the data contradict as a sentence, and what to do next
(the verdict's own sentence: :func:`present.train_report.plain_train_verdict`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .formatting import quantity_of, unit_of, with_se
from .notes import separation_text

__all__ = ["NO_GAIN", "WRITTEN_SE", "WRITTEN_SHARE", "WrittenRow", "compare_written", "wrong_sentence", "steps_after"]

#: The gain's cell when a model has no steady state in a held-out run.
NO_GAIN = "not computed (a model has no steady state in a held-out run)"

#: A written parameter differs from the data when it is more than this many standard errors away:
#: 3, not 2, because a model has ten or so parameters compared at once (at 2 standard errors, one
#: of ten right parameters reads "differs" in 37% of diagnoses; at 3, in 3%).
WRITTEN_SE = 3.0

#: ... and more than this share of the written value: a difference the data resolve but that no
#: one would change a model for (a 0.06% inertia at 40 dB) is not a finding. Parameters written
#: as 0 are compared by their standard errors alone.
WRITTEN_SHARE = 0.01


@dataclass(frozen=True)
class WrittenRow:
    """A parameter of the user's model as written beside what the data say (the adopted model's
    value, else the nominal fit's), and whether the two differ (by more than :data:`WRITTEN_SE`
    standard errors and :data:`WRITTEN_SHARE` of the written value).
    ``provisional``: the data are not explained (the verdict is unexplained), so the fit the data's
    value comes from may itself be wrong: a difference is a lead, not a finding."""

    name: str
    quantity: str
    unit: str
    written: float
    data: float
    std_error: float
    differs: bool
    provisional: bool = False

    @property
    def change(self) -> str:
        """The data's value against the written one, in words ("21% lower")."""
        if self.written == 0:
            return f"{self.data:.3g} instead of 0"
        rel = self.data / self.written - 1
        if abs(rel) >= 10:
            return f"{self.data / self.written:.3g} times"
        size = f"{abs(rel):.0%}" if abs(rel) >= 0.01 else f"{100 * abs(rel):.2g}%"
        return f"{size} {'higher' if rel > 0 else 'lower'}"

    def as_json(self) -> dict:
        return {"written": self.written, "data": self.data, "std_error": self.std_error, "differs": self.differs,
                "change": self.change, "provisional": self.provisional}


def compare_written(written, fit, provisional: bool = False) -> tuple[WrittenRow, ...]:
    """``written`` ((name, value) pairs of the user's model) beside a fit's values and standard
    errors (any :class:`identify.estimates.Estimates`); names the fit lacks are left out.
    ``provisional``: the fit does not explain the data (:attr:`WrittenRow.provisional`)."""
    values = fit.as_dict()
    out = []
    for name, w in written:
        if name not in values:
            continue
        v, se = values[name], fit.std_error(name)
        differs = bool(math.isfinite(se) and abs(v - w) > WRITTEN_SE * se and abs(v - w) > WRITTEN_SHARE * abs(w))
        out.append(WrittenRow(name, quantity_of(name), unit_of(name), w, v, se, differs, provisional))
    return tuple(out)


def wrong_sentence(rows, name=lambda n: n) -> str:
    """The parameters of the user's model the data contradict, as a sentence ("" if none);
    ``name`` gives each parameter's name as the user's bench has it."""
    rows = [r for r in rows if r.differs]
    if not rows:
        return ""
    lead = ("Provisionally (no model explains the data, so the fit these figures come from may be wrong too): as "
            "written, your model has " if any(r.provisional for r in rows) else "As written, your model has ")
    return (lead + "; ".join(
        f"{quantity_of(name(r.name))} = {r.written:.6g}{' ' + unit_of(name(r.name)) if unit_of(name(r.name)) else ''}, "
        f"which the data put at "
        f"{with_se(r.data, r.std_error)} ({r.change})" for r in rows) + ". ")


def steps_after(verdict: str, ambiguities, later_periods_only: bool) -> tuple[str, ...]:
    """What to do next after a diagnosis that is not unexplained, on every bench: tell apart what
    the data cannot, test on another excitation when only later periods were held out, and put
    an adopted cause into the model."""
    out = [f"{a.effects[0]} and {a.effects[1]} explain the same part of the data; to tell them apart: "
           f"{separation_text(a)}" for a in ambiguities]
    if later_periods_only:
        out.append("runs at other drive levels or frequencies: the model was checked only on later periods of the "
                   "same runs")
    if verdict == "explained":
        out.append("put the adopted cause into your model (--mjcf writes the extended model as MuJoCo XML) and "
                   "check it at the operating point that matters to you")
    return tuple(out)
