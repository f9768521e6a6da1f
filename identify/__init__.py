"""Harmonic-balance identification of nonlinear joints (Poterasu et al., eq. 1-12).

Pipeline: :mod:`harmonics` (Fourier coefficients of periodic records) -> :mod:`basis`
(the joint law as a linear combination of terms) -> :mod:`balance` (the rows of
[A]{S} = {F}) -> :mod:`solve` (weighted least squares with standard errors).
:mod:`plant` adds the effects outside the joint and the drive; :mod:`diagnose` ranks the
physical causes of what a nominal model misses.
"""

from .balance import LinearSystem, equivalent_system, single_dof_system, spectral_rate, two_dof_system
from .compare import ParameterComparison, compare, format_table
from .basis import (AngleHat, Coulomb, Iwan, Jenkins, JointLaw, Monomial, Power, QuadraticDamping, RateHat, Term, Viscous,
                    angle_hats, dead_zone, hat_law, hat_matrix, play, polynomial_law, rate_hats)
from .plant import PeriodicDrive, Plant
from .harmonics import fourier_coefficients, max_harmonic, synthesize, to_sine_cosine
from .records import RecordError, SteadyStateRecord
from .solve import FORMS, IdentificationResult, IllConditionedWarning, identify, solve

__all__ = [
    "AngleHat", "ParameterComparison", "compare", "format_table", "IdentificationResult", "IllConditionedWarning", "JointLaw", "LinearSystem", "Monomial", "Power",
    "RateHat", "RecordError", "SteadyStateRecord", "Term", "Viscous", "angle_hats",
    "FORMS", "equivalent_system", "fourier_coefficients", "identify", "hat_law", "hat_matrix", "max_harmonic",
    "polynomial_law", "rate_hats", "single_dof_system", "solve", "spectral_rate", "synthesize",
    "to_sine_cosine", "two_dof_system", "Coulomb", "Iwan", "Jenkins", "QuadraticDamping", "dead_zone", "play",
    "PeriodicDrive", "Plant",
]
