"""The sentences of the diagnosis's values, made in one place: its notes and the reader's
(:mod:`studies.notes`, :mod:`measured.notes`,
:func:`note_text`), why a significant cause was rejected (:data:`identify.causes.Rejection`,
:func:`rejection_text`) and what a fit says about how the file was read
(:func:`plausibility_text`), and why the verdict is what it is (:func:`verdict_text`). The text report, the JSON and the HTML report all read them here,
each parameter named and each size in the units of the user's bench (a slide's: N, m, kg)."""

from __future__ import annotations

from functools import singledispatch

from jointrig.identify.causes import AT_CHANNEL, SAME_PLACE, TO_GROUND, Ambiguity, BelowResolution, FeedsEnergy, NoFalloff, Unphysical
from jointrig.identify.chain import inertia_name
from jointrig.identify.chain_diagnose import ReadWrong, UndeterminedInertia
from jointrig.identify.verdict import CHI2_PER_DOF_OK, Grounds, Verdict
from jointrig.measured.notes import (ClockJitter, CommonMotion, EpochTime, FromValidate, IgnoredColumns,
                                     IncompletePeriod, LaterFundamental, LeastSquaresPeriods, NamesFrom, NoUnits,
                                     OmegaDisagrees, OmegaFromPeriod, PreloadChanges, Resampled, TransientCut,
                                     ZeroPerRun)
from jointrig.studies.holdout import Generalisation
from jointrig.studies.notes import (DIVERGED, NO_INERTIA, NO_STEADY_STATE, NOR_SPANNED, NOT_FOLLOWED, BandCut, BiasUnmeasured,
                                    BodyRests, FidelityCycle, FixedFidelity, JointSticks, NoReplay, NoSpringToFrame, RelativeAngle,
                                    Spanned)
from jointrig.vocab.params import HINGE, Coordinate

from .formatting import quantity_of


@singledispatch
def note_text(note) -> str:
    """A note in words: the reader's (:mod:`measured.notes`) and the diagnosis's (:mod:`studies.notes`)."""
    raise TypeError(f"no words for a note of type {type(note).__name__}")


@note_text.register
def _(note: NoUnits) -> str:
    return ("no units stated in the file or the options: SI assumed (time s, torque N m, angles rad, omega rad/s); "
            "state others with --units, e.g. phi1=deg,time=ms")


@note_text.register
def _(note: NamesFrom) -> str:
    return f"column names and units from {note.side}"


@note_text.register
def _(note: IgnoredColumns) -> str:
    return (f"{note.where}: column(s) {list(note.columns)} ignored (the diagnosis uses run, time, torque, phi1, phi2 or "
            f"phi, omega; a drive train's phi1..phi{note.max_bodies} and torque1..torque{note.max_bodies})")


@note_text.register
def _(note: EpochTime) -> str:
    return (f"run {note.run}: time stamps count from {note.t0_s:.10g} s (absolute, as an epoch time): the run's time "
            f"is taken from its first stamp")


@note_text.register
def _(note: ClockJitter) -> str:
    return (f"run {note.run}: time stamps deviate up to {note.max_deviation:.2g} steps from a uniform clock "
            f"of {note.dt_s:.9g} s (rounding or jitter); the uniform clock is used")


@note_text.register
def _(note: LaterFundamental) -> str:
    return (f"run {note.run}: its fundamental over the whole record, {note.whole:.9g} +- {note.whole_se:.2g} rad/s, "
            f"differs from that after its first period, {note.later:.9g} +- {note.later_se:.2g} rad/s (a transient "
            f"at its start: a record from rest): the later one is used")


@note_text.register
def _(note: OmegaDisagrees) -> str:
    return (f"run {note.run}: column 'omega' ({note.omega:.9g} rad/s) and the record's own period of {note.samples} "
            f"samples ({note.record_omega:.9g} rad/s) differ by {abs(note.omega / note.record_omega - 1):.2g}; the "
            f"record's value is used")


@note_text.register
def _(note: OmegaFromPeriod) -> str:
    return (f"run {note.run}: no 'omega' column; the record repeats every {note.samples} samples: omega = "
            f"{note.omega:.9g} rad/s (the {note.drive}'s line alone gives {note.line_omega:.9g} +- {note.line_se:.2g})")


@note_text.register
def _(note: IncompletePeriod) -> str:
    n, N, P = note.samples, note.per_period, note.periods
    return f"run {note.run}: {n} samples hold {n / N:.4g} periods; the first {n - P * N} samples (an incomplete " \
           f"period, where a record from rest settles) are not used"


@note_text.register
def _(note: Resampled) -> str:
    return (f"run {note.run}: resampled from {note.from_samples} to {note.to_samples} samples per period (harmonics "
            f"0..{note.harmonics})")


@note_text.register
def _(note: LeastSquaresPeriods) -> str:
    src = "the 'omega' column" if note.omega_column else f"the {note.drive}'s line, +- {note.source_se:.2g}"
    share = ", ".join(f"{name} {r:.2%}" for name, r in note.shares)
    return (f"run {note.run}: {note.per_period:.6g} samples per period at omega = {note.omega:.9g} rad/s (from {src}) "
            f"is not a whole number (a fixed sample rate): harmonics 0..{note.harmonics} of each of {note.periods} "
            f"whole periods estimated by least squares on its own samples and synthesised at {note.samples} samples "
            f"per period; residual RMS relative to each channel's RMS (noise plus content above harmonic "
            f"{note.harmonics}): {share}"
            + (f"; the first {note.unused} samples (an incomplete period, where a record from rest settles) are not used" if note.unused > 0 else ""))


@note_text.register
def _(note: TransientCut) -> str:
    return (f"run {note.run}: its first {note.cut} period(s) are a transient (they depart from its last period by more "
            f"than {note.factor:g} times its last two periods' own difference: a record from rest, or a drive just "
            f"switched on): left out, the {note.kept} steady period(s) after them kept")


@note_text.register
def _(note: CommonMotion) -> str:
    if not note.line:
        return (f"run {note.run}: both flywheels rotate steadily at {note.slope:.4g} rad/s on top of the vibration; "
                f"that common rotation is removed (it loads the joint with nothing; a bearing drag at that speed would "
                f"show as a constant torque)")
    return (f"run {note.run}: the whole {note.line} moves steadily at {note.slope:.4g} {note.unit}/s on top of the "
            f"vibration; that common motion is removed")


@note_text.register
def _(note: ZeroPerRun) -> str:
    if note.single:
        return "each run's position taken about its own mean (--zero-per-run)"
    return ("each run's angles taken about their own mean (--zero-per-run): the joint's zero is each run's mean "
            "relative angle, right for a symmetric joint; an asymmetric joint's shift of the mean with the level is "
            "lost")


@note_text.register
def _(note: PreloadChanges) -> str:
    what = "the relative angle's mean" if note.joint == 0 else f"joint {note.joint}'s mean twist"
    return (f"{what} differs between runs by {note.spread_rad:.3g} rad, as the drives' mean does (by "
            f"{note.drive_spread:.4g}): read as a preload that changes between runs (each run's replay holds its "
            f"own), not as encoders zeroed per run")


@note_text.register
def _(note: FromValidate) -> str:
    return f"{note.path} (--validate): {note_text(note.note)}"


@note_text.register
def _(note: BandCut) -> str:
    return (f"harmonics 1..{note.top} fitted, not 1..{note.asked}: run {note.run} holds {note.samples_per_period} "
            f"samples per period, enough for {note.top}")


@note_text.register
def _(note: FixedFidelity) -> str:
    head = f"the model fidelity is fixed at {note.fidelity:g} of each run's largest balanced torque: "
    if note.failure is not None:
        return head + f"{note.model} could not be replayed to measure it ({failures_text(note.failure)})"
    why = (f"the records are noise-free (below {note.noise_free_below:g} of every channel)"
           if note.noise_free_below is not None else
           "a run's noise comes from two periods alone (one degree of freedom per line: its weights give a "
           "chi-square without a finite expectation)")
    return head + (f"{why}, and measured on the replay of {note.model} ({note.measured:.2g} of the balanced torque) it "
                   f"left the best model at chi2/dof {note.chi2_per_dof:.3g}")


@note_text.register
def _(note: FidelityCycle) -> str:
    return (f"the measured fidelity does not settle: measured on the replay of {note.one} it adopts {note.other}, "
            f"measured on {note.other}'s, {note.one}; the catalogue holds no model that its own fidelity keeps")


@note_text.register
def _(note: BodyRests) -> str:
    return (f"run {note.run}: body {note.body} rests {note.rest:.0%} of its period (its rate below "
            f"{note.rest_below:.0%} of its peak; it may stick, held by whatever force its dry friction supplies there, "
            f"not the law's): its equation is balanced only where its rate exceeds {note.balanced_above:.0%} of its "
            f"peak ({note.masked:.0%} of the period left out, in every model compared)")


@note_text.register
def _(note: JointSticks) -> str:
    how = (f"its twist rests {note.rest:.0%} of its period (its twist rate below {note.rest_below:.0%} of its peak)"
           if note.resolved else "its twist is not resolved above the noise (stuck the whole period, or nearly)")
    own = (f", and one of them on its own where the joint slides (its twist rate above {note.balanced_above:.0%} of "
           f"its peak; {note.left_out:.0%} of the period left out)" if note.left_out < 1.0 else " alone")
    return (f"run {note.run}: joint {note.joint} may stick: {how}; while it sticks its torque is whatever holds it, not "
            f"its law's, so its two bodies' equations are balanced as their sum{own} in this run (in every model "
            f"compared)")


@note_text.register
def _(note: NoSpringToFrame) -> str:
    return (f"body {', '.join(str(i) for i in note.bodies)} has no spring to the frame: under the measured drive alone a "
            f"replay would walk off by whatever mean drive the fit misses, so every replay in the rig adds the constant "
            f"load that leaves it without drift, as its position controller (or the bench) held it, and compares the "
            f"motion about its mean")


@note_text.register
def _(note: Spanned) -> str:
    limit = f"within {note.max_periods} periods" + (f" or {note.max_wall_s:g} s" if note.max_wall_s else "")
    return (f"the {note.model} model under the drive of {note.record} (no periodic steady state in the rig {limit}): "
            f"compared over the record's own periods from its measured state instead of a steady state (a model that "
            f"settles slowly, or never, in the rig may still follow the record)")


@note_text.register
def _(note: RelativeAngle) -> str:
    return (f"the relative angle alone ('phi'): the joint's twist moves as one body of inertia J1 J2/(J1 + J2) (J1 "
            f"below) tied to the frame by the joint's law (ground1_* below are the joint's), driven by {note.share:g} "
            f"of the torque (--torque-share: the undriven flywheel's J over J1 + J2"
            + (", from your model" if note.from_model else "") + "); bearing drag and the angle sensors' zero offset "
            "are not sought: they need both angles")


@singledispatch
def rejection_text(rejection, kind: Coordinate = HINGE) -> str:
    """Why a significant cause was rejected, in words, on a bench of ``kind``."""
    raise TypeError(f"no words for a rejection of type {type(rejection).__name__}")


@rejection_text.register
def _(r: Unphysical, kind: Coordinate = HINGE) -> str:
    return f"fitted with an unphysical negative {kind.name(r.name)} = {r.value:.4g}: rejected"


@rejection_text.register
def _(r: FeedsEnergy, kind: Coordinate = HINGE) -> str:
    return (f"the extended model would hold a negative {kind.name(r.name)} = {r.value:.4g} +- {r.std_error:.2g}: it "
            f"would feed energy in")


@rejection_text.register
def _(r: BelowResolution, kind: Coordinate = HINGE) -> str:
    then = f"{r.slips} that never sticks is dry friction (see {r.friction})" if r.slips else "no free play is resolved"
    return (f"its {r.size} {r.value:.3g} {kind.unit} is below the {kind.sensor} resolution {r.resolution:.2g} "
            f"{kind.unit}: {then}")


@rejection_text.register
def _(r: NoFalloff, kind: Coordinate = HINGE) -> str:
    return (f"its Stribeck rate {r.velocity:.3g} {kind.unit}/s is above every run's rate amplitude (at most "
            f"{r.rate_top:.3g} {kind.unit}/s): the friction does not fall off within the data; it is dry friction (see "
            f"{r.friction})")


def _inertias(bodies, kind: Coordinate) -> str:
    return ", ".join(f"{quantity_of(kind.name(inertia_name(i)))} = {v:.3g} +- {se:.2g}" for i, v, se in bodies)


@singledispatch
def plausibility_text(finding, kind: Coordinate = HINGE) -> str:
    """What a train's fit says about how its file was read, in words, on a bench of ``kind``."""
    raise TypeError(f"no words for a finding of type {type(finding).__name__}")


@plausibility_text.register
def _(f: ReadWrong, kind: Coordinate = HINGE) -> str:
    said = ([f"the fitted inertia of body(ies) {', '.join(str(i) for i, _, _ in f.bodies)} "
             f"({_inertias(f.bodies, kind)}) is no body's"] if f.bodies else []) + (
        [f"joint(s) {', '.join(map(str, f.joints))} come out with a negative stiffness or damping (they would feed "
         f"energy in)"] if f.joints else [])
    return (" and ".join(said) + ": check that the position columns (phi1..phiN, x1..xN) are the bodies in their order "
            "along the line (two swapped give this), that each drive column torque<i> (force<i>) acts on body i, and "
            "the units (angles in rad, not deg; torques in N m, not N mm)")


@plausibility_text.register
def _(f: UndeterminedInertia, kind: Coordinate = HINGE) -> str:
    return (f"the inertia of body(ies) {', '.join(str(i) for i, _, _ in f.bodies)} ({_inertias(f.bodies, kind)}) is "
            f"not determined by these runs (within two standard errors of zero): at too few drive frequencies an "
            f"inertia and a stiffness act alike on a sine; runs at more frequencies tell them apart")


def no_replay_text(f: NoReplay) -> str:
    """Why a model could not be simulated under a run's drive, in words."""
    if f.why == NO_INERTIA:
        bad = ", ".join(f"J{i} = {v:.3g}" for i, v in f.inertias)
        if not f.model:
            return "a fitted inertia is no body's"
        return f"the {f.model} model has no body's inertia ({bad} kg m^2): it cannot be simulated"
    if f.why == DIVERGED:  # a fitted model's instability: no step size of the user's to change
        who = f"the {f.model} model" if f.model else "the fitted model"
        return (f"{who} diverges in the rig under the {'measured ' if f.model else ''}drive of {f.run} (MuJoCo "
                f"warned: {f.detail}): a fitted value makes it unstable")
    if not f.model:  # the fidelity's replay of the fitted runs: its model is named where it is quoted
        return f"no periodic steady state under the drive of {f.run}: {f.detail}"
    if f.why == NOT_FOLLOWED:
        return f"the {f.model} model does not follow the measured drive of {f.run}: {f.detail}"
    head = f"the {f.model} model reaches no periodic steady state under the measured drive of {f.run}"
    if f.why == NOR_SPANNED:
        return head + f", nor follows it over its {f.periods} periods: {f.detail}"
    if f.why == NO_STEADY_STATE:
        return head + (f": {f.detail}" if f.detail else "")
    raise ValueError(f"no words for a replay that failed by {f.why!r}")


def failures_text(failures) -> str:
    """The replays that failed (:class:`studies.notes.NoReplay`), in words, one after the other."""
    return "; ".join(no_replay_text(f) for f in failures)


def bias_unmeasured_text(why: BiasUnmeasured) -> str:
    """Why the method's bias on a model was not measured, in words."""
    if why.smooth:
        return "the nominal law is smooth: not measured"
    if why.failures:
        return f"the model could not be replayed on the fitted runs ({failures_text(why.failures)})"
    return "no replay of the fitted runs was made"


def verdict_text(v: Verdict) -> str:
    """Why the verdict is what it is, in words: its figures against their bounds and what the
    held-out data say (the verdict's reason in the text, the JSON and the HTML report)."""
    if v.grounds is Grounds.UNCHECKED:
        why = failures_text(v.unchecked) or "no held-out run"
        if not v.causes:
            return f"the nominal model could not be checked on held-out runs: {why}; it cannot be the train"
        return f"the best extension ({' + '.join(v.causes)}) is not adopted: {why}"
    held = "error on the held-out later periods" if v.later_periods else "held-out error"
    figures = (f"chi2/dof {v.chi2_per_dof:.3g} (at most {CHI2_PER_DOF_OK:g}), {held} {v.error_ratio:.3g} times what a "
               f"right model misses (at most {v.bound:.3g})")
    names = " + ".join(v.causes)
    verb = "explains" if len(v.causes) == 1 else "explain"
    nominal = (f"{v.nominal_ratio:.3g} times what it would miss were it right, at most {v.nominal_bound:.3g}; "
               f"gain {v.gain:.3g}")
    return {
        Grounds.NOMINAL_FITS: lambda: f"the nominal model explains the data to the noise: {figures}",
        Grounds.NOMINAL_MISFITS: lambda: ("no catalogued cause is significant, but the nominal model does not explain "
                                          f"the data: {figures}"),
        Grounds.CONFIRMED: lambda: (f"{names} {verb} the data: {figures}; the nominal model's {held} is "
                                    f"{v.nominal_ratio:.3g} times what it would miss were it right (at most "
                                    f"{v.nominal_bound:.3g}): the held-out runs confirm the extension"),
        Grounds.NOMINAL_LOST: lambda: (f"{names} {verb} the data: {figures}; the nominal model reaches no periodic "
                                       f"steady state in held-out run(s) {', '.join(v.nominal_lost)}, the extended "
                                       f"model does"),
        Grounds.FIT_EVIDENCE: lambda: (f"{names} {verb} the data: {figures}; the held-out runs do not resolve it (the "
                                       f"nominal model's {held} is {nominal}): adopted on the fit's evidence"),
        Grounds.NOT_CONFIRMED: lambda: (f"the best extension ({names}) is not confirmed: {figures}, but the nominal "
                                        f"model predicts the held-out runs as well ({held} {nominal}); nothing is adopted"),
        Grounds.FAILS_VALIDATION: lambda: (f"the best extension ({names}) fails validation: {figures}; nothing is "
                                           f"adopted"),
        Grounds.FIDELITY_CYCLE: lambda: (f"no model is adopted under its own fidelity: the balance's misfit measured "
                                         f"on the replay of {v.cycle[0]} leads the diagnosis to {v.cycle[1]}, and "
                                         f"measured on that model's replay, back to {v.cycle[0]}; the last ("
                                         f"{names or 'the nominal model'}: {figures}) is not adopted"),
    }[v.grounds]()


def separation_text(a: Ambiguity) -> str:
    """What would tell two causes apart, in words: the drive that separates them best (with the
    Fisher information per run of every drive), or the runs that would where no drive is named."""
    one, two = a.effects
    if a.unplaced == TO_GROUND:
        return (f"{one} and {two}: no linearised drive information for a law to ground; runs at other levels would "
                f"tell them apart")
    if a.unplaced == AT_CHANNEL:
        return (f"{one} and {two}: a channel's lag or scale is not a place on the line; runs at several frequencies "
                f"at one level tell a lag (its phase grows with the frequency) from a law, a static reading against a "
                f"reference a channel's scale")
    if a.unplaced == SAME_PLACE:
        return f"{one} and {two} act at the same place, so every drive moves them alike; {a.excitation} would"
    if a.separating_drive is None:
        raise ValueError(f"an ambiguity of {one} and {two} names neither a drive nor why not")
    ranked = ", ".join(f"flywheel {d}: {v:.3g}" for d, v in a.information)
    return (f"driving flywheel {a.separating_drive} separates {one} from {two} best (Fisher information per run at "
            f"the measured frequencies and torque, linearised: {ranked})")


def generalisation_text(g: Generalisation, kind: Coordinate = HINGE) -> str:
    """What the held-out data ask of the model, in words, drive levels in the bench's units."""
    if g.later_periods:
        return (f"the later {', '.join(str(p) for p in g.later_periods)} period(s) of the same run(s), fitted on their "
                f"earlier periods: with {g.runs} run(s) no run of another level or frequency can be held out, so this "
                f"checks the steady state, not a new excitation")
    unit = kind.drive_unit

    def distinct(values):
        return ", ".join(f"{v:.4g}" for v in values)

    kinds = []
    if g.another_excitation is not None:
        kinds.append("another excitation (held-out drives with "
                     + ("several lines, the fit's sines)" if g.another_excitation else "one line, the fit's several)"))
    if g.levels_outside:
        kinds.append(f"extrapolation in drive level ({distinct(g.levels_outside)} {unit}, outside the "
                     f"fitted {g.level_range[0]:.4g}-{g.level_range[1]:.4g} {unit})")
    if g.omegas_outside:
        kinds.append(f"extrapolation in frequency ({distinct(g.omegas_outside)} rad/s, outside the "
                     f"fitted {g.omega_range[0]:.4g}-{g.omega_range[1]:.4g} rad/s)")
    if g.new_omegas:
        kinds.append(f"frequencies the fit did not see ({distinct(g.new_omegas)} rad/s, inside its range)")
    if g.new_levels:
        kinds.append(f"drive levels between the fitted ones ({distinct(g.new_levels)} {unit})")
    if not kinds:
        return "the held-out runs repeat frequencies and drive levels of the fit (another realisation only)"
    return "the held-out runs test " + "; ".join(kinds)
