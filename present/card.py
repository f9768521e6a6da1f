"""The joint card as people read it (from :func:`studies.joint_card.cards_of_train`): its text
(:func:`format_card`, printed by ``jointrig card`` and ``diagnose --card``), its JSON, its figure
(PNG) and the sentence on Masing's rule."""

from __future__ import annotations

import io
import math

import numpy as np

from jointrig.identify.card import MASING_FIDELITY, JointCard, MasingCheck
from jointrig.studies.joint_card import CardReport

from .formatting import sig, with_se, with_se_or
from .notes import verdict_text

__all__ = ["format_card", "card_warning", "model_name", "mode_text", "RUNS_INERTIAS", "masing_text", "card_json", "card_png", "point_cells", "slope_text"]


def point_cells(p) -> tuple[str, str, str, str]:
    """A card point's secant stiffness, natural frequency, damping ratio and dissipation, each
    with its standard error, or "none" where the joint has none (no stiffness: no mode)."""
    return tuple(with_se_or(getattr(p, k), getattr(p, k + "_std"), "none") for k in (
        "secant_stiffness_Nm_per_rad", "natural_frequency_rad_s", "damping_ratio", "dissipation_J_per_cycle"))


def slope_text(c: JointCard) -> str:
    """A card's dissipation slope (and rate exponent) with standard errors, in words where none
    is fitted (fewer than two amplitudes that dissipate)."""
    text = with_se_or(c.dissipation_slope, c.dissipation_slope_std, "none (fewer than two amplitudes)")
    if math.isfinite(c.rate_exponent):
        text += f" (rate exponent {with_se(c.rate_exponent, c.rate_exponent_std)})"
    return text


def format_card(card) -> str:
    def row(src, p):
        k, wn, zeta, e = point_cells(p)
        return (f"  {src:13s} {p.run:>4s} {sig(p.amplitude_rad):>9s} {sig(p.omega_rad_s, 4):>7s} "
                f"{k:>18s} {wn:>18s} {zeta:>20s} {e:>18s}")

    slope = slope_text

    a_unit, k_unit = card.units
    inertia = "kg" if a_unit == "m" else "kg m^2"
    warning = card_warning(card)
    lines = ([f"WARNING: {warning}"] if warning else []) + [
             f"Joint card{f' of {card.place}' if card.place else ''} ({model_name(card)}; {mode_text(card)}, Je = "
             f"{sig(card.model.inertia_kgm2, 4)} {inertia}); runs at their drive frequency omega (measured with "
             f"{RUNS_INERTIAS} inertias), the model there and on its backbone (omega = omega_n):",
             f"  {'source':13s} {'run':>4s} {f'A [{a_unit}]':>9s} {'omega':>7s} {f'k_sec [{k_unit}]':>18s} "
             f"{'omega_n [rad/s]':>18s} {'damping ratio':>20s} {'E per cycle [J]':>18s}"]
    for p, m in zip(card.runs.points, card.model_at_runs.points):
        lines += [row("runs", p), row("model at run", m)]
    model = card.model.points
    if not any(math.isfinite(p.natural_frequency_rad_s) for p in model):
        lines.append("  backbone: none (the law has no stiffness here, so no mode)")
    for p in ([model[0], model[len(model) // 2], model[-1]] if len(model) >= 3 else model):
        if math.isfinite(p.natural_frequency_rad_s):
            lines.append(row("backbone", p))
    lines.append(f"  dissipation slope d lnE / d lnA: runs {slope(card.runs)}, model at the runs "
                 f"{slope(card.model_at_runs)}, backbone {slope(card.model)} (viscous 2 and rate exponent 1, "
                 f"dry friction 1 and 0, micro-slip 3 + chi)")
    lines.append("  " + masing_text(card.masing))
    return "\n".join(lines)


#: Whose inertias the runs' rows of a card are measured with.
RUNS_INERTIAS = "the adopted model's"


def model_name(card: CardReport) -> str:
    """Which model the card describes: the extended one with its causes, or the nominal one and why."""
    if card.causes:
        return f"extended: {' + '.join(card.causes)}"
    return f"nominal (verdict {card.verdict.verdict})" if card.verdict is not None else "nominal"


def mode_text(card: CardReport) -> str:
    """What the card's mode is, in words: a body on what holds it to the frame, or a joint's two
    bodies on the joint alone."""
    if card.joint == 0:
        return f"mode of the body on what holds it to the frame, its {card.kind.inertia}"
    j = card.joint
    return f"mode of bodies {j} and {j + 1} on joint {j} alone, J{j} J{j + 1} / (J{j} + J{j + 1})"


def card_warning(card) -> str:
    """Why the card's model may not be the joint, in words ("" when the diagnosis adopted it)."""
    if card.unadopted is None:
        return ""
    return (f"this card describes the nominal model, which the diagnosis did NOT adopt: the verdict is unexplained "
            f"({verdict_text(card.unadopted)}). Compare the rows from the runs with the model's before using it.")


def masing_text(check: MasingCheck) -> str:
    """One sentence on Masing's rule for a card's runs."""
    if not check.runs or check.discrepancy != check.discrepancy:  # NaN: nothing compared
        return "Masing check: fewer than two runs whose loops can be compared."
    how = (f"the runs' loops imply backbones {100 * check.discrepancy:.3g}% apart (of the tip torque; runs "
           f"{check.worst_pair[0]} and {check.worst_pair[1]}; noise {100 * check.noise:.2g}%, fidelity "
           f"{100 * MASING_FIDELITY:.2g}%)")
    verdict = {True: "they follow Masing's rule, as a joint of sliders (Jenkins, Iwan, dry friction) does",
               False: "they do not follow Masing's rule: the damping depends on the rate or the loops change "
                      "otherwise than their backbone says",
               None: "too noisy to tell"}[check.follows]
    skipped = f"; runs {', '.join(check.skipped)} are not simple loops" if check.skipped else ""
    return f"Masing check: {how}: {verdict}{skipped}."


def card_json(card: CardReport, *, source: str = "", input_sha256: str = "") -> dict:
    """The card as JSON: ``amplitudes`` lists every point (``source``: "runs", "model_at_runs" (the
    model at each run's amplitude and drive frequency) or "model" (its backbone, at the natural
    frequency)), each value with its ``_std``; the dissipation slopes (and, for runs at several
    frequencies, the rate exponent) of each with their standard errors."""
    points = ([{"source": "runs", **p.as_json()} for p in card.runs.points]
              + [{"source": "model_at_runs", **p.as_json(), "run": r.run}
                 for p, r in zip(card.model_at_runs.points, card.runs.points)]
              + [{"source": "model", **p.as_json()} for p in card.model.points])
    out = {"source": source, "input_sha256": input_sha256, "model": model_name(card),
            "model_adopted": card.unadopted is None, "warning": card_warning(card) or None,
            "runs_inertias": RUNS_INERTIAS,
            "units": "SI: rad, rad/s, N m/rad, N m s/rad, J per cycle; damping ratio dimensionless",
            "what": "amplitude-dependent joint card: secant stiffness, natural frequency and damping ratio of the "
                    "joint's mode (relative coordinate, inertia Je), dissipation per cycle; model by the "
                    "single-harmonic describing function at the natural frequency, runs from their first harmonics "
                    "and loop areas at the drive frequency",
            "amplitudes": points,
            "dissipation_slope": {"runs": card.runs.dissipation_slope, "runs_std": card.runs.dissipation_slope_std,
                                  "model_at_runs": card.model_at_runs.dissipation_slope,
                                  "model_at_runs_std": card.model_at_runs.dissipation_slope_std,
                                  "model": card.model.dissipation_slope,
                                  "model_std": card.model.dissipation_slope_std},
            "rate_exponent": {"runs": card.runs.rate_exponent, "runs_std": card.runs.rate_exponent_std,
                              "model_at_runs": card.model_at_runs.rate_exponent,
                              "model_at_runs_std": card.model_at_runs.rate_exponent_std},
            "masing": card.masing.as_json(),
            "runs_card": card.runs.as_json(), "model_card": card.model.as_json(),
            "model_at_runs_card": card.model_at_runs.as_json()}
    if card.place:
        out = {"place": card.place, "mode": mode_text(card), **out}
    if card.units[0] == "m":  # a slide's: the amplitude in m, the stiffness in N/m, the damping in N s/m
        out = _renamed(out, {"amplitude_rad": "amplitude_m", "amplitude_rad_std": "amplitude_m_std",
                             "secant_stiffness_Nm_per_rad": "secant_stiffness_N_per_m",
                             "secant_stiffness_Nm_per_rad_std": "secant_stiffness_N_per_m_std",
                             "equivalent_damping_Nms_per_rad": "equivalent_damping_Ns_per_m",
                             "inertia_kgm2": "mass_kg"})
        out["units"] = "SI: m, rad/s, N/m, N s/m, J per cycle, kg; damping ratio dimensionless"
    return out


def _renamed(obj, names: dict):
    """``obj`` with its keys renamed at every depth."""
    if isinstance(obj, dict):
        return {names.get(k, k): _renamed(v, names) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_renamed(v, names) for v in obj]
    return obj


def card_png(card: CardReport, title: str = "joint card") -> bytes:
    """Four panels over the relative amplitude: natural frequency, damping ratio, dissipation per
    cycle (log-log, with the slopes) and secant stiffness; the model's backbone as a curve with
    its +-2 standard-error band, the runs as points with +-2 standard-error bars, the model at
    each run's drive frequency as open squares (what the runs are compared with)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    m, r = card.model.points, card.runs.points
    am = np.array([p.amplitude_rad for p in m])
    ar = np.array([p.amplitude_rad for p in r])
    a_unit, k_unit = card.units
    panels = (("natural_frequency_rad_s", "natural frequency [rad/s]"), ("damping_ratio", "damping ratio [-]"),
              ("dissipation_J_per_cycle", "dissipation per cycle [J]"),
              ("secant_stiffness_Nm_per_rad", f"secant stiffness [{k_unit}]"))
    for ax, (key, label) in zip(axes.flat, panels):
        y = np.array([getattr(p, key) for p in m])
        s = np.array([getattr(p, key + "_std") for p in m])
        ax.plot(am, y, color="tab:blue", label=f"model backbone ({model_name(card)})")
        if np.all(np.isfinite(s)):
            ax.fill_between(am, y - 2 * s, y + 2 * s, color="tab:blue", alpha=0.2, lw=0, label="model +-2 s.e.")
        yr = np.array([getattr(p, key) for p in r])
        sr = np.array([getattr(p, key + "_std") for p in r])
        ax.errorbar(ar, yr, yerr=np.where(np.isfinite(sr), 2 * sr, 0.0), fmt="o", color="k", ms=4, capsize=3,
                    label="runs (+-2 s.e.), at their drive frequency")
        ym = np.array([getattr(p, key) for p in card.model_at_runs.points])
        ax.plot(ar, ym, "s", mfc="none", color="tab:blue", ms=7, label="model at the runs' frequencies")
        ax.set(xlabel=f"{'amplitude' if card.place.startswith('body') else 'relative amplitude'} A [{a_unit}]",
               ylabel=label, xscale="log")
        _amplitude_ticks(ax, np.concatenate([am, ar]))
        if key == "dissipation_J_per_cycle":
            every = np.concatenate([y, yr, ym])
            if np.any(np.isfinite(every) & (every > 0)):  # a law that dissipates nothing has no log scale
                ax.set_yscale("log")
            ax.set_title(f"slope d lnE/d lnA: runs {_slope(card.runs)}, model at runs {_slope(card.model_at_runs)}, "
                         f"backbone {_slope(card.model)}", fontsize=8)
        ax.grid(alpha=0.3, which="both")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def _amplitude_ticks(ax, amplitudes: np.ndarray) -> None:
    """Log-axis ticks that never overlap: labels only at 1, 2 and 5 times a power of ten (at
    powers of ten alone beyond three decades), plain numbers, no labels on the minor ticks
    (matplotlib labels them in a range of about a decade, and they crowded into each other
    when the amplitudes spanned just over one)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    finite = amplitudes[np.isfinite(amplitudes) & (amplitudes > 0)]
    span = float(finite.max() / finite.min()) if finite.size else 1.0
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0,) if span > 1000 else (1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _slope(c: JointCard) -> str:
    if not math.isfinite(c.dissipation_slope):
        return "n/a"
    return f"{c.dissipation_slope:.3g} +- {c.dissipation_slope_std:.2g}" if math.isfinite(
        c.dissipation_slope_std) else f"{c.dissipation_slope:.3g}"
