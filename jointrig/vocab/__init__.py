"""The vocabulary the rig and the identifier share, owned by neither.

* :mod:`law`: the joint law as a linear combination of terms (paper eq. 1-2, 8-9). A term
  describes itself once: its mathematics (scalar path for the rig's callback, array path for
  the identifier's columns), its model-file fields, its C case and its physical sign.
* :mod:`plant`: the law with the effects outside the joint (bearing drag, drive delay) and the
  periodic drive.
* :mod:`records`: steady-state records (whole periods sampled uniformly, SI units), checked on
  entry.

Nothing here imports another part of jointrig: ``identify`` (the mathematics), ``measured``
(the readers) and ``rig`` (the simulator) import it.
"""

from .law import (TERM_CLASSES, AngleHat, ContactDamping, Coulomb, FieldError, Iwan, Jenkins, JointLaw, Monomial,
                  NativeTerm, Power, QuadraticDamping, RateHat, Stribeck, Term, Viscous, angle_hats, dead_zone, hat_law, hat_matrix,
                  law_terms_from_fields, play, polynomial_law, rate_hats)
from .plant import PeriodicDrive, Plant, drive_of_record, effect_parameters
from .records import RecordError, SteadyStateRecord

__all__ = [
    "TERM_CLASSES", "AngleHat", "ContactDamping", "Coulomb", "FieldError", "Iwan", "Jenkins", "JointLaw", "Monomial",
    "NativeTerm",
    "Power", "QuadraticDamping", "RateHat", "Stribeck", "Term", "Viscous", "angle_hats", "dead_zone", "hat_law",
    "hat_matrix", "law_terms_from_fields", "play", "polynomial_law", "rate_hats",
    "PeriodicDrive", "Plant", "drive_of_record", "effect_parameters", "RecordError", "SteadyStateRecord",
]
