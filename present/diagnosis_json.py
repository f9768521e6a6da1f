"""One JSON document for every diagnosis, whatever the bench (pure).

Two flywheels, a drive train of up to eight bodies and a single axis write the same keys
(:data:`KEYS`, in that order), SI with the unit in each parameter's name (a slide's in N, m,
kg); what one bench does not compute is null or empty, never missing, so a user's script reads
every file the same way. ``docs/diagnosis-json.md`` describes each key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Optional, Sequence

from jointrig.identify.causes import Ambiguity, CauseScore
from jointrig.identify.verdict import Verdict
from jointrig.vocab.params import Coordinate

from .notes import rejection_text, separation_text, verdict_text

__all__ = ["SCHEMA", "KEYS", "VERDICT_KEYS", "FIDELITY_KEYS", "RULED_OUT_KEYS", "PRELOAD_KEYS", "FIT_KEYS", "VALIDATION_KEYS", "RIGHT_KEYS", "RUN_KEYS", "CAUSE_KEYS", "FitJson", "RunJson",
           "ValidationJson", "DiagnosisJson", "finite", "schema_problems"]

#: The document's name and version: a script checks it before it reads the keys.
SCHEMA = "jointrig-diagnosis/8"
#: The top-level keys, in the order written (the demo ``jointrig diagnose-chain`` adds ``demo``
#: last: its truth model and settings).
KEYS = ("schema", "source", "input_sha256", "units", "bench", "verdict", "band_harmonics", "fidelity", "fit_runs",
        "held_out_runs", "noise_std_per_sample", "nominal", "causes", "extended", "ruled_out", "preloads", "ambiguities", "as_written",
        "validation", "plausibility", "misfit_character", "misfit_surface", "next_measurements", "notes")
BENCH_KEYS = ("kind", "n_bodies", "form", "model")
#: ``grounds``: the value of :class:`identify.verdict.Grounds` the verdict comes from
VERDICT_KEYS = ("verdict", "reason", "grounds")
FIDELITY_KEYS = ("how", "relative_misfit", "replayed_model", "fixed_runs", "statement")
RULED_OUT_KEYS = ("label", "effect", "place", "magnitude_name", "limit", "std_error", "detection_probability")
PRELOAD_KEYS = ("joint", "mean", "std_error", "per_run", "unit")
FIT_KEYS = ("chi2", "dof", "chi2_per_dof", "parameters", "std_errors", "std_error_dofs", "intervals_95")
EXTENDED_KEYS = ("effects", "tried", "steps") + FIT_KEYS + ("on_search_bound",)
VALIDATION_KEYS = ("kind", "generalisation", "statement", "measure", "unit", "nominal_error", "extended_error",
                   "noise_floor", "right_model", "gain", "note", "per_run")
RIGHT_KEYS = ("error", "bound", "noise", "propagated", "method", "rig", "dof", "estimate_dof", "alpha", "directions",
              "draws", "method_unmeasured")
RUN_KEYS = ("run", "held_out", "omega_rad_s", "drive_amplitude", "nominal_error", "extended_error", "noise_floor",
            "right_model_error", "no_steady_state")
CAUSE_KEYS = ("label", "effect", "place", "score", "significant", "delta_chi2", "n_params", "p_value", "magnitude",
              "signature", "note", "parameters")


def finite(obj):
    """JSON has no inf/NaN: non-finite numbers become null."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


@dataclass(frozen=True)
class FitJson:
    """One fitted model: chi-square, its degrees of freedom, the parameters with standard errors,
    each error's degrees of freedom (None: taken as known) and each 95% interval's half width."""

    chi2: float
    dof: int
    parameters: dict
    std_errors: dict
    std_error_dofs: dict = field(default_factory=dict)
    intervals_95: dict = field(default_factory=dict)

    @classmethod
    def of(cls, fit, name: Callable[[str], str] = str, added: Optional[Mapping[str, float]] = None) -> "FitJson":
        """From either diagnosis's fit (``identify.estimates.RowFit``); ``name`` renames a parameter
        for the user's bench (a slide's, :func:`vocab.params.linear_name`); ``added``: constants
        added to parameters (a twist's zero: the mean taken out before the fit)."""
        p = {n: v + (added or {}).get(n, 0.0) for n, v in fit.parameters().items()}
        dofs = {name(n): fit.std_error_dof(n) for n in p}
        return cls(float(fit.chi2), int(fit.dof), {name(n): float(v) for n, v in p.items()},
                   {name(n): fit.std_error(n) for n in p},
                   {n: (d if math.isfinite(d) else None) for n, d in dofs.items()},
                   {name(n): fit.interval(n) for n in p})

    def as_json(self) -> dict:
        return {"chi2": self.chi2, "dof": self.dof, "chi2_per_dof": self.chi2 / max(self.dof, 1),
                "parameters": dict(self.parameters), "std_errors": dict(self.std_errors),
                "std_error_dofs": dict(self.std_error_dofs), "intervals_95": dict(self.intervals_95)}


@dataclass(frozen=True)
class RunJson:
    """One run replayed in the rig: its setting, each model's error, the error noise alone gives
    (None where not computed per run) and why a model has no steady state there (model -> why)."""

    run: str
    held_out: bool
    omega_rad_s: float
    drive_amplitude: float
    nominal_error: float
    extended_error: float
    noise_floor: Optional[float] = None
    no_steady_state: tuple = ()
    #: the error a right model has on this run alone (noise, propagated and method parts)
    right_model_error: Optional[float] = None

    def as_json(self) -> dict:
        return {"run": self.run, "held_out": self.held_out, "omega_rad_s": self.omega_rad_s,
                "drive_amplitude": self.drive_amplitude, "nominal_error": self.nominal_error,
                "extended_error": self.extended_error, "noise_floor": self.noise_floor,
                "right_model_error": self.right_model_error, "no_steady_state": dict(self.no_steady_state)}


@dataclass(frozen=True)
class ValidationJson:
    """The replay of the held-out data in the rig: what was held out (``kind``:
    ``held_out_runs`` or ``held_out_periods``) and what that tests, the error ``measure`` in
    ``unit``, each model's error on the held-out data, the noise floor, what a right model misses
    and the bound on it (``right_model``) and the gain."""

    kind: str
    generalisation: str
    statement: str
    measure: str
    unit: str
    nominal_error: float
    extended_error: float
    noise_floor: float
    gain: float
    per_run: tuple[RunJson, ...]
    note: str = ""
    #: what a right model misses here (:data:`RIGHT_KEYS`; None where not measured)
    right_model: Optional[dict] = None

    def as_json(self) -> dict:
        return {"kind": self.kind, "generalisation": self.generalisation, "statement": self.statement,
                "measure": self.measure, "unit": self.unit, "nominal_error": self.nominal_error,
                "extended_error": self.extended_error, "noise_floor": self.noise_floor,
                "right_model": dict(self.right_model) if self.right_model is not None else None, "gain": self.gain,
                "note": self.note, "per_run": [r.as_json() for r in self.per_run]}


def cause_json(s: CauseScore, kind: Coordinate) -> dict:
    """A cause's score (:meth:`CauseScore.as_json`) with its parameters named for the bench and
    why it was rejected, if it was, in words (:func:`present.notes.rejection_text`)."""
    out = s.as_json()
    out["magnitude"] = {**out["magnitude"], "name": kind.name(out["magnitude"]["name"])}
    out["note"] = rejection_text(s.note, kind) if s.note is not None else ""
    out["parameters"] = {kind.name(n): v for n, v in out["parameters"].items()}
    return out


@dataclass(frozen=True)
class DiagnosisJson:
    """Everything a diagnosis's JSON holds (:data:`KEYS`), filled by the report
    (``present.train_report``)."""

    source: str
    input_sha256: str
    units: str
    #: how the bodies move, with the words and units that go with it: hinge (rad, N m, kg m^2) or
    #: slide (m, N, kg); every parameter is named for it (:meth:`vocab.params.Coordinate.name`)
    kind: Coordinate
    n_bodies: int
    #: which runs were fitted: "train" (every body's position) or "relative" (the relative angle alone)
    form: str
    model: Optional[str]
    verdict: Verdict
    band_harmonics: int
    fit_runs: tuple[str, ...]
    held_out_runs: tuple[str, ...]
    noise_std_per_sample: dict
    nominal: FitJson
    causes: tuple[CauseScore, ...]
    #: the causes the diagnosis added, in order, and the causes the verdict adopts (labels)
    steps: tuple[CauseScore, ...]
    adopted: tuple[str, ...]
    extended: FitJson
    ambiguities: tuple[Ambiguity, ...]
    as_written: dict
    validation: ValidationJson
    notes: tuple[str, ...] = ()
    plausibility: tuple[str, ...] = ()
    misfit_character: Optional[dict] = None
    misfit_surface: Optional[dict] = None
    next_measurements: tuple[str, ...] = ()
    #: the fidelity the final model's weights carry (:data:`FIDELITY_KEYS`)
    fidelity: Optional[dict] = None
    #: what the runs rule out (:data:`RULED_OUT_KEYS`), one object per cause not adopted
    ruled_out: tuple = ()
    #: the mean torque (force) each joint whose zero the data determine carries (:data:`PRELOAD_KEYS`)
    preloads: tuple = ()
    #: ``(parameter, side, bound)`` of each adopted cause's profiled parameter on an end of its search
    on_bounds: tuple = ()

    def as_json(self) -> dict:
        out = {"schema": SCHEMA, "source": self.source, "input_sha256": self.input_sha256, "units": self.units,
               "bench": {"kind": self.kind, "n_bodies": self.n_bodies, "form": self.form, "model": self.model},
               "verdict": {"verdict": self.verdict.verdict, "reason": verdict_text(self.verdict),
                           "grounds": self.verdict.grounds.value},
               "band_harmonics": self.band_harmonics,
               "fidelity": dict(self.fidelity or {"how": None, "relative_misfit": None, "replayed_model": None,
                                                  "statement": ""}),
               "fit_runs": list(self.fit_runs),
               "held_out_runs": list(self.held_out_runs), "noise_std_per_sample": dict(self.noise_std_per_sample),
               "nominal": self.nominal.as_json(), "causes": [cause_json(s, self.kind) for s in self.causes],
               "extended": {"effects": list(self.adopted), "tried": [s.label for s in self.steps],
                            "steps": [cause_json(s, self.kind) for s in self.steps], **self.extended.as_json(),
                            "on_search_bound": [{"parameter": self.kind.name(p), "side": side, "bound": bound}
                                                for p, side, bound in self.on_bounds]},
               "ruled_out": [dict(r) for r in self.ruled_out], "preloads": [dict(r) for r in self.preloads],
               "ambiguities": [ambiguity_json(a) for a in self.ambiguities], "as_written": dict(self.as_written),
               "validation": self.validation.as_json(), "plausibility": list(self.plausibility),
               "misfit_character": self.misfit_character, "misfit_surface": self.misfit_surface,
               "next_measurements": list(self.next_measurements), "notes": list(self.notes)}
        return finite(out)


def ambiguity_json(a: Ambiguity) -> dict:
    """An ambiguity in the diagnosis document: the two causes, what would separate them in words,
    and the separating drive's body (null where none is named)."""
    return {"effects": list(a.effects), "excitation": separation_text(a), "separating_drive_body": a.separating_drive}


def schema_problems(doc: dict) -> list[str]:
    """What in a document departs from :data:`KEYS` and the nested key lists: missing or extra
    keys, in the wrong order (empty: it is a jointrig diagnosis document)."""
    problems = []

    def keys(where: str, obj, expected: Sequence[str]) -> None:
        if not isinstance(obj, dict):
            problems.append(f"{where}: expected an object, got {type(obj).__name__}")
        elif tuple(obj) != tuple(expected):
            problems.append(f"{where}: keys {list(obj)}, expected {list(expected)}")

    keys("document", doc, KEYS + (("demo",) if "demo" in doc else ()))
    if problems:
        return problems
    if doc["schema"] != SCHEMA:
        problems.append(f"schema: {doc['schema']!r}, expected {SCHEMA!r}")
    keys("bench", doc["bench"], BENCH_KEYS)
    keys("verdict", doc["verdict"], VERDICT_KEYS)
    keys("fidelity", doc["fidelity"], FIDELITY_KEYS)
    for i, r in enumerate(doc["ruled_out"] if isinstance(doc["ruled_out"], list) else []):
        keys(f"ruled_out[{i}]", r, RULED_OUT_KEYS)
    for i, r in enumerate(doc["preloads"] if isinstance(doc["preloads"], list) else []):
        keys(f"preloads[{i}]", r, PRELOAD_KEYS)
    keys("nominal", doc["nominal"], FIT_KEYS)
    keys("extended", doc["extended"], EXTENDED_KEYS)
    keys("validation", doc["validation"], VALIDATION_KEYS)
    if isinstance(doc["validation"], dict) and doc["validation"].get("right_model") is not None:
        keys("validation.right_model", doc["validation"]["right_model"], RIGHT_KEYS)
    for i, r in enumerate(_list_at(doc["validation"], "per_run")):
        keys(f"validation.per_run[{i}]", r, RUN_KEYS)
    for where, items in (("causes", doc["causes"]), ("extended.steps", _list_at(doc["extended"], "steps"))):
        for i, c in enumerate(items if isinstance(items, list) else []):
            keys(f"{where}[{i}]", c, CAUSE_KEYS)
    return problems


def _list_at(obj, key: str) -> list:
    """``obj[key]`` where ``obj`` is an object holding a list there, else empty (its absence or
    type is already among the problems, from the object's keys)."""
    value = obj.get(key) if isinstance(obj, dict) else None
    return value if isinstance(value, list) else []
