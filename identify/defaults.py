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
#: (studies.chain_validate; the fidelity's replays step finer, :data:`FIDELITY_STEP_SHARE`); fine
#: enough for the stiffest joints of the benches (k 20000 N m/rad on 2 kg m^2: omega_n dt = 0.007).
REPLAY_MAX_STEP_S = 5e-5

#: The share of :data:`REPLAY_MAX_STEP_S` the rig steps at when it replays a fitted model to
#: measure what the balance misses (the fidelity, studies.chain_validate.rig_replay): at the
#: replay step the rig's own error at a stick-slip kink (MuJoCo's friction constraint on the step
#: grid) outweighs the balance's misfit it is meant to measure. On noise-free records of the
#: paper's joint with 20 N m of dry friction (tests/bench_sim.py, 4 runs) the balance misses
#: 1.3e-6..2.0e-5 of each run's balanced torque; the rig's replay at 5e-5 s reads 4.2e-5..1.1e-4
#: (4 to 30 times that), at a quarter of it 4.1e-6..4.0e-5, at a sixteenth 3.8e-6..2.5e-5, for
#: 1.6, 6.3 and 25 s of replays (7.2 and 2.5 times the records' misfit over all rows at the first two).
#: A quarter: most of the rig's error gone, for about 5 s more a pass on the README's example.
FIDELITY_STEP_SHARE = 0.25

#: The most replay steps one period may take (periods up to 10 s at REPLAY_MAX_STEP_S; a slow
#: positioning axis's reference has a few seconds): every run is replayed for every fit the
#: diagnosis weighs, so a longer period (most often a time column in ms read as s) is refused
#: before any work (``jointrig diagnose``).
MAX_REPLAY_STEPS_PER_PERIOD = 2e5

#: The diagnosis's false-alarm rate: of a cause's evidence (identify.causes.evidence) and of the
#: held-out comparison's bound (studies.chain_validate.RightModelError.bound).
DEFAULT_ALPHA = 1e-3
