"""Which runs a diagnosis holds out for validation, and what they ask of the model (pure).

Runs of another kind than the fit where the data allow (another excitation, an inner level, an
inner frequency), else every third; with fewer than :data:`MIN_RUNS_TO_HOLD_OUT` runs each run's
later periods are held out (:func:`studies.chain_validate.split_chain_periods`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from jointrig.identify.misfit import distinct_settings, same_setting

__all__ = ["Generalisation", "MIN_RUNS_TO_HOLD_OUT", "MIN_PERIODS_TO_SPLIT", "HELD_OUT_RUNS", "HELD_OUT_PERIODS", "default_holdout",
           "holdout_of_another_kind", "generalisation_kind"]


#: Fewer runs than this: no run can be held out (the fit needs the rest), so each run's periods
#: are split instead (:func:`split_periods`).
MIN_RUNS_TO_HOLD_OUT = 3
#: Whole periods a run needs for its periods to be split into a fit part of at least two (two
#: periods give the fit its noise estimate from their difference) and a held-out part of at least
#: one (its noise floor then comes from the fit's noise per sample). A record from rest of three
#: to four periods of a slow reference leaves about this many once its transient is cut.
MIN_PERIODS_TO_SPLIT = 3
#: What the validation held out, in the verdict's JSON (``validation.kind``).
HELD_OUT_RUNS, HELD_OUT_PERIODS = "held_out_runs", "held_out_periods"


def default_holdout(n_runs: int) -> tuple[int, ...]:
    """Runs held out of the fit: every third, starting with the second (indices 1, 4, 7, ...),
    so the lowest and the highest setting of a sorted sweep stay in the fit and the held-out
    runs test interpolation between fitted ones."""
    if n_runs < 3:
        raise ValueError(f"{n_runs} run(s): need at least 3 to hold one out for validation")
    return tuple(range(1, n_runs, 3))


def _near(v: float, settings: Sequence[float]) -> int:
    return int(np.argmin([abs(v - s) for s in settings])) if settings else -1


def holdout_of_another_kind(settings: Sequence[tuple[float, float, int]]) -> tuple[int, ...]:
    """Runs to hold out so that validation tests a kind of run the fit did not see, wherever the
    data allow (pure): ``settings`` are per run (omega rad/s, drive amplitude N m, the drive's
    lines besides the fundamental that stand out of the noise).

    In this order, the first that leaves at least three runs to fit:
    1. another excitation: with sines and multi-line drives (multisines) both present, the
       smaller group is held out, and the model fitted on one excitation predicts the other;
    2. another level: with three or more drive levels, every other inner level (the middle one
       of three), so the held-out runs sit between fitted levels at fitted frequencies;
    3. another frequency: likewise with three or more frequencies;
    4. else every third run (:func:`default_holdout`).
    A sorted 3 x 3 sweep (frequency-major) gives the same runs as :func:`default_holdout`.
    """
    n = len(settings)
    if n < 3:
        raise ValueError(f"{n} run(s): need at least 3 to hold one out for validation")
    multi = [i for i, (_, _, e) in enumerate(settings) if e > 0]
    single = [i for i in range(n) if i not in multi]
    if multi and single:
        held = multi if len(multi) <= len(single) else single
        if n - len(held) >= 3:
            return tuple(held)
    for axis in (1, 0):  # drive level first, then frequency
        values = [s[axis] for s in settings]
        levels = distinct_settings(values)
        if len(levels) >= 3:
            inner = set(range(1, len(levels) - 1, 2))
            held = [i for i, v in enumerate(values) if _near(v, levels) in inner]
            if held and n - len(held) >= 3:
                return tuple(held)
    return default_holdout(n)


@dataclass(frozen=True)
class Generalisation:
    """What the held-out data ask of a model fitted on the rest (its words:
    :func:`present.notes.generalisation_text`). ``later_periods``: the held-out data are the later
    periods (their counts, per run) of the ``runs`` runs fitted on their earlier ones. Else what
    the held-out runs test: ``another_excitation`` (True: held-out drives of several lines against
    the fit's sines; False: the reverse; None: the same kind), drive levels (N m; N on a slide) and
    frequencies (rad/s) outside the fitted ``level_range`` and ``omega_range`` (extrapolation),
    frequencies the fit did not see inside its range, drive levels between the fitted ones; none
    of them: another realisation only."""

    later_periods: tuple = ()
    runs: int = 0
    another_excitation: Optional[bool] = None
    levels_outside: tuple = ()
    level_range: tuple = ()
    omegas_outside: tuple = ()
    omega_range: tuple = ()
    new_omegas: tuple = ()
    new_levels: tuple = ()


def generalisation_kind(fit: Sequence[tuple[float, float, int]], held: Sequence[tuple[float, float, int]]
                        ) -> Generalisation:
    """What the held-out runs ``(omega rad/s, drive level N m, extra drive lines)`` ask of a model
    fitted on ``fit``: another excitation (a multi-line drive against sines, or the reverse),
    drive levels or frequencies outside the fitted range (extrapolation), frequencies the fit did
    not see inside its range, or only interpolation between fitted levels at fitted frequencies.
    Frequencies and levels count as equal within 1%; each list holds the distinct settings."""
    def close(a, values):
        return any(same_setting(a, v, 0.01) for v in values)

    def distinct(values):
        return tuple(distinct_settings(values, 0.01))

    other = None
    if {e > 0 for *_, e in held} - {e > 0 for *_, e in fit}:
        other = any(e > 0 for *_, e in held)
    fw, fl = [w for w, _, _ in fit], [a for _, a, _ in fit]
    hw, hl = [w for w, _, _ in held], [a for _, a, _ in held]
    out_l = [a for a in hl if (a < min(fl) and not close(a, fl)) or (a > max(fl) and not close(a, fl))]
    out_w = [w for w in hw if (w < min(fw) and not close(w, fw)) or (w > max(fw) and not close(w, fw))]
    new_w = [w for w in hw if w not in out_w and not close(w, fw)]
    new_l = [a for a in hl if a not in out_l and not close(a, fl)]
    return Generalisation(another_excitation=other, levels_outside=distinct(out_l), level_range=(min(fl), max(fl)),
                          omegas_outside=distinct(out_w), omega_range=(min(fw), max(fw)), new_omegas=distinct(new_w),
                          new_levels=distinct(new_l))
