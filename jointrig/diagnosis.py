"""What the simulation gets wrong about measured runs, from Python: the diagnosis
``jointrig diagnose`` runs, as one call that returns its result.

    from jointrig import diagnose

    d = diagnose("examples/bench_dry_friction.csv")
    print(d.text())                       # the report the command prints
    d.verdict                             # "no_misfit", "explained" or "unexplained"
    d.reason                              # why, in words
    d.parameters()                        # the adopted model's parameters by name (SI units in the names)
    d.std_errors()                        # their standard errors
    d.json()                              # the command's --json, as a dict

Every keyword is the command's option of the same name (``--max-causes`` is ``max_causes``), with
its default, and bad input raises :class:`DiagnosisInputError` naming the file, run, column or
option and what was expected, before any long work (the command exits 2 on it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

from jointrig.identify.defaults import DEFAULT_MAX_CAUSES, MAX_REPLAY_STEPS_PER_PERIOD, REPLAY_MAX_STEP_S

__all__ = ["diagnose", "Diagnosis", "DiagnosisInputError", "VALIDATE_PREFIX"]

#: Before a run label of the ``validate`` record: which record it came from.
VALIDATE_PREFIX = "validate:"

PathLike = Union[str, Path]


class DiagnosisInputError(ValueError):
    """Input the diagnosis cannot use: the message names the file, run, column or option and what
    was expected."""


@dataclass(frozen=True)
class Diagnosis:
    """The result of :func:`diagnose`.

    Attributes:
      report: the diagnosis of the fitted runs, the held-out runs' validation in the rig and the
        verdict (:class:`studies.chain_validate.TrainReport`: ``report.diagnosis`` holds the
        nominal and final fits, the causes scored and adopted; ``report.validation`` the
        held-out errors; ``report.verdict`` the verdict with its grounds and figures, :class:`identify.verdict.Verdict`).
      runs: the runs as read (:class:`measured.runs.LoadedRuns`: run labels, records in SI units,
        the reader's notes, the input's SHA-256).
      source: the data's path, as given.
      torque_on: where the drive acts on two flywheels (``flywheel1``, ``flywheel2``).
    """

    report: object
    runs: object
    source: str
    torque_on: str = "flywheel1"

    @property
    def verdict(self) -> str:
        """``no_misfit``, ``explained`` or ``unexplained`` (:attr:`reason` says why in words;
        ``report.verdict`` holds the grounds and figures as values)."""
        return self.report.verdict.verdict

    @property
    def reason(self) -> str:
        """Why the verdict is what it is, in words: the figures against their bounds (the report's
        first line after the verdict)."""
        from jointrig.present.notes import verdict_text

        return verdict_text(self.report.verdict)

    @property
    def relative(self) -> bool:
        """The data hold the relative angle alone: the joint's twist is one body tied to the frame."""
        return self.runs.torque_share is not None

    def parameters(self) -> dict[str, float]:
        """The adopted model's parameters (the extended model if explained, else the nominal one)
        by name; each name carries its SI unit (``joint1_k_Nm_per_rad``, ``m1_kg``)."""
        return {k: float(v) for k, v in self.report.adopted_fit.parameters().items()}

    def std_errors(self) -> dict[str, float]:
        """Each of :meth:`parameters`' standard errors (NaN where none is determined)."""
        f = self.report.adopted_fit
        return {k: float(f.std_error(k)) for k in f.parameters()}

    def intervals(self) -> dict[str, float]:
        """Half the width of each of :meth:`parameters`' 95% intervals: Student's t at its standard
        error's degrees of freedom times the error (1.96 times it where the error is taken as known;
        :meth:`identify.estimates.Estimates.interval`)."""
        f = self.report.adopted_fit
        return {k: float(f.interval(k)) for k in f.parameters()}

    def text(self) -> str:
        """The report ``jointrig diagnose`` prints."""
        from jointrig.present.train_report import format_train_report

        return format_train_report(self.report, source=self.source, notes=self.runs.notes)

    def json(self) -> dict:
        """The diagnosis as the command's ``--json`` writes it (docs/diagnosis-json.md)."""
        from jointrig.present.train_report import train_report_json

        return train_report_json(self.report, source=self.source, notes=self.runs.notes,
                                 input_sha256=self.runs.sha256)

    def model_xml(self, header: str = "") -> str:
        """The adopted model as a rig model file (MJCF with ``jointrig_*`` fields), the command's
        ``--mjcf``; from the relative angle alone, as the two flywheels it stands for."""
        from jointrig.identify.chain_diagnose import plant_and_inertias
        from jointrig.rig.chain import chain_model_xml, two_flywheels_of_relative

        plant, J = plant_and_inertias(self.report.adopted_fit)
        driven = sorted({i for r in self.runs.records for i, t in enumerate(r.torques_Nm, start=1) if t is not None})
        if self.relative:
            plant, J, driven = two_flywheels_of_relative(plant, J[0], self.runs.torque_share, self.torque_on)
            header += (f"\nFrom the relative angle alone: J1, J2 from the identified J1 J2/(J1 + J2) = "
                       f"{J[0] * J[1] / sum(J)!r} kg m^2 and the torque share {self.runs.torque_share:g}")
        return chain_model_xml(plant, J, driven, header=header, kind=self.runs.kind)


def read_data(data: PathLike, *, validate: Optional[PathLike] = None, columns: Optional[str] = None,
              units: Optional[str] = None, zero_per_run: bool = False, torque_on: str = "flywheel1",
              torque_share: float = 0.5):
    """The runs of ``data`` (a file or a folder), then, labelled ``validate:<run>``, those of
    ``validate`` (the same bench's), as :class:`measured.runs.LoadedRuns`."""
    from jointrig.measured.notes import FromValidate
    from jointrig.measured.runs import read_runs

    kw = dict(columns=columns, units=units, zero_per_run=zero_per_run, torque_on=torque_on, torque_share=torque_share)
    loaded = read_runs(Path(data), **kw)
    if validate is None:
        return loaded
    other = read_runs(Path(validate), **kw)
    if (other.records[0].n_flywheels, other.torque_share, other.kind) != \
            (loaded.records[0].n_flywheels, loaded.torque_share, loaded.kind):
        raise DiagnosisInputError(f"--validate {validate}: its columns are another bench's than {data}'s "
                                  f"(expected the same angles and drives)")
    ids = tuple(VALIDATE_PREFIX + r for r in other.run_ids)
    notes = tuple(FromValidate(str(validate), n) for n in other.notes)
    return replace(loaded, run_ids=loaded.run_ids + ids, records=loaded.records + other.records,
                   notes=loaded.notes + notes)


def load_model(path: PathLike, torque_on: str = "flywheel1"):
    """The user's model file as the line of its bodies (:func:`rig.chain.load_model`; two
    flywheels' driven where ``torque_on`` says)."""
    from jointrig.rig.chain import load_model as load_line
    from jointrig.rig.model import RigModelError

    try:
        return load_line(Path(path), (2,) if torque_on == "flywheel2" else (1,))
    except RigModelError as err:
        raise DiagnosisInputError(f"--model: {err}") from None


def held_out_runs(ids: Sequence[str], holdout: Optional[Sequence[str]], validate: bool, data: PathLike
                  ) -> "list[int] | None":
    """The indices of the runs ``holdout`` names (with a ``validate`` record: every run of it;
    None without either), refusing a label not in the file."""
    from jointrig.measured.runs import RunsFileError

    if validate:
        return [i for i, r in enumerate(ids) if r.startswith(VALIDATE_PREFIX)]
    if not holdout:
        return None
    unknown = [h for h in holdout if h not in ids]
    if unknown:
        raise RunsFileError(f"{data}: --holdout names run(s) {unknown} not in the file; runs are {list(ids)}")
    return sorted({ids.index(h) for h in holdout})


def diagnose(data: PathLike, *, model: Optional[PathLike] = None, holdout: Optional[Sequence[str]] = None,
             validate: Optional[PathLike] = None, columns: Optional[str] = None, units: Optional[str] = None,
             zero_per_run: bool = False, zeroed: bool = False, torque_on: str = "flywheel1",
             torque_share: float = 0.5, band: int = 20, alpha: float = 1e-3, fidelity: Optional[float] = None,
             max_causes: int = DEFAULT_MAX_CAUSES, progress: Optional[Callable[[str], None]] = None,
             before: Optional[Callable[[object], None]] = None) -> Diagnosis:
    """Diagnose the measured runs of ``data`` (a file or a folder; docs/data-formats.md): fit the
    nominal model (``model``'s laws, else the paper's at every joint), rank the catalogued causes
    of what it misses, extend it, and validate both models in the MuJoCo rig on held-out runs
    (``holdout``'s labels, every run of ``validate``, else runs of another kind than the fit).

    ``progress`` is called with each step's message; ``before`` with the runs as read, before the
    long work (a caller's own checks, such as the command's output paths per joint).

    Raises :class:`DiagnosisInputError` or :class:`measured.runs.RunsFileError` (bad input) and
    ``rig.simulate.SimulationError`` (a simulation that failed)."""
    from jointrig.identify.chain import ChainIdentifiabilityError
    from jointrig.measured.runs import TORQUE_ON
    from jointrig.rig.chain import relative_chain, torque_share as share_of
    from jointrig.rig.model import RigModelError

    if validate is not None and holdout:
        raise DiagnosisInputError("--validate holds out every run of another record and --holdout some of this one's: "
                                  "give one of them")
    if torque_on not in TORQUE_ON:
        raise DiagnosisInputError(f"--torque-on must be {', '.join(TORQUE_ON[:-1])} or {TORQUE_ON[-1]}, got {torque_on!r}")
    rig_model = load_model(model, torque_on) if model is not None else None
    if rig_model is not None and rig_model.n_flywheels == 2:  # the relative angle's share, from the model
        torque_share = share_of(rig_model, torque_on)
    loaded = read_data(data, validate=validate, columns=columns, units=units, zero_per_run=zero_per_run,
                       torque_on=torque_on, torque_share=torque_share)
    if before is not None:
        before(loaded)
    if loaded.torque_share is not None and rig_model is not None:
        try:  # the model's relative-angle form
            rig_model = relative_chain(rig_model)
        except RigModelError as err:
            raise DiagnosisInputError(f"--model: {err}") from None
    try:
        return _diagnosed(loaded, rig_model, data=data, model_path=model, holdout=holdout, validate=validate,
                          zeroed=zeroed, torque_on=torque_on, band=band, alpha=alpha, fidelity=fidelity,
                          max_causes=max_causes, progress=progress)
    except ChainIdentifiabilityError as err:
        raise DiagnosisInputError(str(err)) from None


def _diagnosed(loaded, model, *, data, model_path, holdout, validate, zeroed, torque_on, band, alpha, fidelity,
               max_causes, progress) -> Diagnosis:
    """:func:`diagnose` on the runs as read (a line of bodies), validated in a rig of the user's
    model or of the file's bodies and drives."""
    from jointrig.measured.runs import RunsFileError
    from jointrig.present.notes import note_text
    from jointrig.rig.chain import rig_of_bodies
    from jointrig.studies.notes import RelativeAngle
    from jointrig.studies.chain_validate import MIN_PERIODS_TO_SPLIT, MIN_RUNS_TO_HOLD_OUT, run_train_diagnosis, written_of

    N = loaded.records[0].n_flywheels
    driven = sorted({i for r in loaded.records for i, t in enumerate(r.torques_Nm, start=1) if t is not None})
    relative = loaded.torque_share is not None  # the relative angle alone: one body
    if model is not None and (model.n_flywheels, model.kind) != (N, loaded.kind):
        raise DiagnosisInputError(f"--model {model_path} has {model.n_flywheels} bodies on {model.kind}s, {data} "
                                  f"{N} on {loaded.kind}s")
    if model is not None:
        missing = sorted(set(driven) - set(model.driven))
        if missing:
            raise DiagnosisInputError(f"--model {model_path} has no drive on body(ies) {missing}, which {data} "
                                      f"drives (torque{missing[0]}); add <motor name=\"drive{missing[0]}\" ...>")
    ids = list(loaded.run_ids)
    _refuse_long_periods(data, ids, loaded.records)
    held = held_out_runs(ids, holdout, validate is not None, data)
    if held is not None and validate is None and len(ids) - len(held) < 3:
        raise DiagnosisInputError(f"--holdout leaves {len(ids) - len(held)} run(s) to fit; expected at least 3")
    if validate is not None:
        fitted = [r for i, r in enumerate(loaded.records) if i not in held]
        other = [r for i, r in enumerate(loaded.records) if i in held]

        def drives(rs) -> set:
            return {i for r in rs for i, t in enumerate(r.torques_Nm, start=1) if t is not None}
        if {r.n_flywheels for r in other} != {N} or not drives(other) <= drives(fitted):
            raise DiagnosisInputError(f"--validate {validate}: {other[0].n_flywheels} bodies driven at "
                                      f"{sorted(drives(other))}, {data} {N} driven at {sorted(drives(fitted))}: "
                                      f"expected the same bench")
    if held is None and len(ids) < MIN_RUNS_TO_HOLD_OUT + 1:  # each run's later periods are held out
        short = [f"{rid} ({r.n_periods})" for rid, r in zip(ids, loaded.records) if r.n_periods < MIN_PERIODS_TO_SPLIT]
        if short:
            raise RunsFileError(f"{data}: {len(ids)} run(s), and run(s) {', '.join(short)} hold fewer than "
                                f"{MIN_PERIODS_TO_SPLIT} whole periods: the diagnosis needs {MIN_RUNS_TO_HOLD_OUT + 1} "
                                f"runs (some held out for validation), runs of at least {MIN_PERIODS_TO_SPLIT} "
                                f"steady periods (the later half held out), or a separate validation record "
                                f"(--validate OTHER)")
    notes = (RelativeAngle(loaded.torque_share, model is not None),) if relative else ()
    for n in (*loaded.notes, *notes):
        if progress is not None:
            progress(f"note: {note_text(n)}")
    rig = model if model is not None else rig_of_bodies(N, driven, loaded.kind)
    written = written_of(model) if model is not None else ()
    report = run_train_diagnosis(loaded.records, run_ids=ids, rig=rig, holdout=held, written=written, band=band,
                                 alpha=alpha, fidelity=fidelity, max_causes=max_causes, zeroed=zeroed,
                                 progress=progress, form="relative" if relative else "train")
    return Diagnosis(replace(report, notes=notes + report.notes), loaded, str(data), torque_on)


def _refuse_long_periods(data: PathLike, ids: list, records) -> None:
    """Refuse, before the diagnosis, runs whose period the rig would replay in more than
    :data:`MAX_REPLAY_STEPS_PER_PERIOD` steps (a time column in ms read as s, most often)."""
    import math

    from jointrig.measured.runs import RunsFileError

    slow = [(rid, r.omega_rad_s) for rid, r in zip(ids, records)
            if 2 * math.pi / r.omega_rad_s / REPLAY_MAX_STEP_S > MAX_REPLAY_STEPS_PER_PERIOD]
    if slow:
        longest = max(2 * math.pi / w for _, w in slow)
        runs = ", ".join(f"{rid} ({w:.4g} rad/s)" for rid, w in slow[:5]) + (", ..." if len(slow) > 5 else "")
        raise RunsFileError(
            f"{data}: run(s) {runs} have periods of up to {longest:.3g} s: the diagnosis replays every run in the "
            f"rig many times at steps of {REPLAY_MAX_STEP_S:g} s, {longest / REPLAY_MAX_STEP_S:.3g} steps a period, and would "
            f"take many minutes; expected periods of at most {MAX_REPLAY_STEPS_PER_PERIOD * REPLAY_MAX_STEP_S:g} s (omega >= "
            f"{2 * math.pi / (MAX_REPLAY_STEPS_PER_PERIOD * REPLAY_MAX_STEP_S):.3g} rad/s). If the time column is not in "
            f"seconds, give its unit (--units time=ms, or a header 'time [ms]')")
