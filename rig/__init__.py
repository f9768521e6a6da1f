"""The MuJoCo virtual test rig: two flywheels joined by a nonlinear joint, driven harmonically.

Submodules beyond the core: :mod:`measurement` (noise model), :mod:`validate` (diagnosis with
validation in the rig), :mod:`diagnosis_report`, :mod:`hidden_effects` (ground-truth cases),
:mod:`native_callback` (the callback in C).
"""

from .model import DEFAULT_MODEL, RigModel, RigModelError, law_from_model, load_rig, plant_from_model
from .simulate import (SettleInfo, SimulationConfig, SimulationError, SteadyStateNotReached, commit_state,
                       make_callback, passive_callback, simulate_steady_state)

__all__ = [
    "DEFAULT_MODEL", "RigModel", "RigModelError", "SettleInfo", "SimulationConfig", "SimulationError",
    "SteadyStateNotReached", "law_from_model", "load_rig", "make_callback", "passive_callback",
    "simulate_steady_state", "plant_from_model", "commit_state",
]
