"""The MuJoCo virtual test rig: two flywheels joined by a nonlinear joint, driven harmonically."""

from .model import DEFAULT_MODEL, RigModel, RigModelError, law_from_model, load_rig
from .simulate import (SettleInfo, SimulationConfig, SimulationError, SteadyStateNotReached,
                       make_callback, passive_callback, simulate_steady_state)

__all__ = [
    "DEFAULT_MODEL", "RigModel", "RigModelError", "SettleInfo", "SimulationConfig", "SimulationError",
    "SteadyStateNotReached", "law_from_model", "load_rig", "make_callback", "passive_callback",
    "simulate_steady_state",
]
