"""Defaults of the diagnosis that the command line shows in its help (a light module: importing
it loads neither scipy nor the rig, so ``jointrig diagnose --help`` starts at once)."""

#: Model-fidelity floor, relative to each run's largest balanced torque (see
#: :func:`identify.chain_diagnose.diagnose_chain`).
DEFAULT_FIDELITY = 1e-3

#: The most causes a diagnosis adopts (``--max-causes``): the evidence decides below it (each
#: must be significant beside the ones before it and pass parsimony); the limit only bounds the
#: work on a train of eight bodies, where every round scores every cause at every place.
DEFAULT_MAX_CAUSES = 4

#: The rig's largest integrator step when a diagnosis replays a run (s): the held-out validation
#: and the fidelity replays (studies.chain_validate); fine enough for the stiffest joints of the
#: benches (k 20000 N m/rad on 2 kg m^2: omega_n dt = 0.007).
REPLAY_MAX_STEP_S = 5e-5

#: The most replay steps one period may take (periods up to 10 s at REPLAY_MAX_STEP_S; a slow
#: positioning axis's reference has a few seconds): every run is replayed for every fit the
#: diagnosis weighs, so a longer period (most often a time column in ms read as s) is refused
#: before any work (``jointrig diagnose``).
MAX_REPLAY_STEPS_PER_PERIOD = 2e5

#: The diagnosis's false-alarm rate: of a cause's evidence (identify.causes.evidence) and of the
#: held-out comparison's bound (studies.chain_validate.RightModelError.bound).
DEFAULT_ALPHA = 1e-3
