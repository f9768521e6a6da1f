"""Harmonic-balance identification of nonlinear joints (Poterasu et al., eq. 1-12).

Pipeline: :mod:`harmonics` (Fourier coefficients of periodic records) -> :mod:`balance` (the
rows of [A]{S} = {F}, one column per term of the joint law) -> :mod:`solve` (weighted least
squares with standard errors); :mod:`diagnose` ranks the physical causes of what a nominal
model misses. The law, its terms, the plant and the records it works on are the shared
vocabulary of :mod:`jointrig.vocab`, which the rig uses too.
"""

from .balance import LinearSystem, equivalent_system, single_dof_system, spectral_rate, two_dof_system
from .compare import ParameterComparison, compare, format_table
from .harmonics import fourier_coefficients, max_harmonic, synthesize, to_sine_cosine
from .solve import FORMS, IdentificationResult, IllConditionedWarning, identify, solve

__all__ = [
    "ParameterComparison", "compare", "format_table", "IdentificationResult", "IllConditionedWarning",
    "LinearSystem", "FORMS", "equivalent_system", "fourier_coefficients", "identify", "max_harmonic",
    "single_dof_system", "solve", "spectral_rate", "synthesize", "to_sine_cosine", "two_dof_system",
]
