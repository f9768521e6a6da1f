"""Studies on the rig: what is run with the simulator rather than inside it.

Sweeps (:mod:`sweep`, :mod:`chain_sweep`), the Monte Carlo of the estimators (:mod:`montecarlo`),
the diagnosis validated in the rig (:mod:`validate`, :mod:`chain_validate`), the hidden-effect
cases (:mod:`hidden_effects`), the joint card beside its runs (:mod:`joint_card`), the virtual
phase-resonance test (:mod:`phase_resonance`) and the card held against it (:mod:`card_check`),
and the peer methods of the benchmarks (:mod:`peers`). They import the simulator (``rig``) and
the identifier (``identify``), never the presentation (``present``).
"""
