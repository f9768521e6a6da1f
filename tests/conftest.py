"""Shared fixtures: rigs and sweeps are simulated once per test session."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from jointrig.rig import DEFAULT_MODEL, SimulationConfig, load_rig
from jointrig.rig.runtime import limit_threads
from jointrig.studies.sweep import DEFAULT_PLAN, records_of, run_sweep

# pytest-xdist already runs one test per core: a diagnosis scores its causes in this process
# (and so do the commands the tests start), not in forked workers of its own. The parallel
# path has its own test (test_diagnose.py).
os.environ.setdefault("JOINTRIG_WORKERS", "1")

def blueprint_views(rrd_path) -> tuple[list[str], list[str]]:
    """(display names, view origins) of the rerun blueprint stored in a recording file."""
    import rerun as rr

    reader = rr.chunk.RrdReader(str(rrd_path))
    names, origins = [], []
    for chunk in reader.store(store=reader.blueprints()[0]).stream().to_chunks():
        batch = chunk.to_record_batch()
        for col in batch.schema.names:
            if col.endswith("display_name"):
                names += [v[0] for v in batch.column(col).to_pylist() if v]
            elif col.endswith("space_origin"):
                origins += [v[0] for v in batch.column(col).to_pylist() if v]
    return names, origins


def _children() -> set[int]:
    """This process's child processes, zombies included (from /proc: Linux, like CI)."""
    me, out = os.getpid(), set()
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    stat = f.read()
            except OSError:  # gone meanwhile
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == me:
                out.add(int(entry))
    return out


#: The README's example file (two flywheels, 60 N m of dry friction at the joint, 0.1% noise).
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "bench_dry_friction.csv"


@pytest.fixture(scope="session")
def example_outputs(tmp_path_factory):
    """The README's example diagnosed by ``jointrig diagnose`` once per worker, with every output
    the command writes, and the result object it made: ``(folder, Diagnosis)``. The folder holds
    ``d.json``, ``d.rrd``, ``d.html``, ``card.json``, ``card.png`` and ``identified.xml``. The
    command calls ``jointrig.diagnose`` with the same defaults as the Python API, so the object is
    what ``jointrig.diagnose(EXAMPLE)`` returns. Two workers, as on a user's machine (this
    session sets one): the causes are scored in forked processes and the recording and report
    come from the writer process (``jointrig.parallel.WarmProcess``). The tests that read it carry
    ``pytest.mark.xdist_group("example")``, so one worker computes it (about 40 s)."""
    import jointrig.diagnosis
    from jointrig.commands import diagnose

    out = tmp_path_factory.mktemp("example")
    made = []
    real = jointrig.diagnosis.diagnose

    def keep(*args, **kwargs):
        made.append(real(*args, **kwargs))
        return made[-1]

    argv = [str(EXAMPLE), "--json", str(out / "d.json"), "--rrd", str(out / "d.rrd"), "--report", str(out / "d.html"),
            "--card", str(out / "card.json"), "--card-png", str(out / "card.png"), "--mjcf",
            str(out / "identified.xml"), "-q"]
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("JOINTRIG_WORKERS", "2")
        mp.setattr(jointrig.diagnosis, "diagnose", keep)
        assert diagnose.main(argv) == 0
    assert len(made) == 1
    return out, made[0]


@pytest.fixture(scope="session")
def example_diagnosis(example_outputs):
    """``jointrig.diagnose`` of the README's example (:func:`example_outputs`'s object)."""
    return example_outputs[1]


@pytest.fixture
def no_children_left():
    """Whatever children the test process had before (pytest-xdist's own), fork_map leaves none
    of its own behind: every worker it forked has exited and been reaped."""
    before = _children()
    yield
    assert _children() <= before


#: Tests of the native callback need a C compiler to build it.
needs_cc = pytest.mark.skipif(not (shutil.which("cc") or shutil.which("gcc")),
                              reason="no C compiler to build the native callback")

RECORD_FIELDS = ("time_s", "phi1_rad", "phi2_rad", "rate1_rad_s", "rate2_rad_s", "torque_Nm")


def assert_identical_records(a, b):
    """Bit for bit, every channel, where both records come from the same code on the same
    machine: a serial sweep against a parallel or dask one (the executors only reorder
    independent points), a store read back, a rollout against stepping with the same callback.
    Deterministic code on the same inputs gives the same bits, so no tolerance is needed."""
    for f in RECORD_FIELDS:
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)


#: Python against C callbacks: each channel within this fraction of its peak. Both repeat the
#: same arithmetic in the same order (C compiled with -ffp-contract=off), but an elementary
#: function (exp, tanh, sin, cos) may be reached by another implementation from the
#: interpreter than from the C library on some machines and round its last bit otherwise
#: (about 1e-16 relative per evaluation). Over a run of 1e4-1e5 steps that grew to 2e-10 of
#: the signal on a 2-core AMD EPYC (a Stribeck law, issue 51); 1e-8 leaves a 50x margin, and the
#: smallest deliberate fault of scripts/deliberate_faults.py (a slip torque 4% high) moves a
#: record by more than 1e-3 of its peak.
CALLBACK_RTOL = 1e-8


#: A record simulated in another process that the test did not fork (a dask worker: started
#: afresh, its thread and allocator settings the nanny's, the model recompiled from its text)
#: against the same record simulated here: each channel within this fraction of its peak. The
#: same code on the same inputs gives the same bits within one process image (threads, forks, a
#: store read back: :func:`assert_identical_records`), but a fresh interpreter need not take the
#: same path through numpy's and the C library's elementary functions: with this test process on
#: one x86-64 CPU (emulated, ``qemu-x86_64 -cpu Haswell``) and the workers on another, a dask
#: sweep's records differed by 3.3e-16 rad, 2.3e-12 of the signal. A worker simulating the wrong
#: law (what these tests guard) moves a record far more: the light joint's damping 1% off moves
#: flywheel 1's angle by 4e-3 of its peak, the file's law instead of the client's by 0.98.
PROCESS_RTOL = CALLBACK_RTOL


def assert_records_agree(a, b, fields=RECORD_FIELDS, rtol=CALLBACK_RTOL):
    """The Python and the C callback's records: every channel within ``rtol`` of its peak
    (:data:`CALLBACK_RTOL` says why not bit for bit)."""
    for f in fields:
        x, y = np.asarray(getattr(a, f)), np.asarray(getattr(b, f))
        assert x.shape == y.shape, f
        np.testing.assert_allclose(y, x, rtol=0, atol=rtol * max(np.abs(x).max(), 1e-300), err_msg=f)


# One BLAS thread per pytest worker: the suite runs on both cores (pytest-xdist, -n 2).
limit_threads()

MODELS_DIR = Path(DEFAULT_MODEL).parent
#: Two-flywheel rig models (checked by rig.load_rig); the one-coordinate oscillator is separate.
RIG_MODELS = sorted(MODELS_DIR.glob("two_flywheels*.xml"))
ALL_MODELS = sorted(MODELS_DIR.glob("*.xml"))


@pytest.fixture(scope="session")
def rig():
    return load_rig(DEFAULT_MODEL)


@pytest.fixture(scope="session")
def hat_rig():
    return load_rig(MODELS_DIR / "two_flywheels_hat.xml")


@pytest.fixture(scope="session")
def default_sweep(rig):
    """The default sweep of the paper's joint (18 runs, ~3 s)."""
    return records_of(run_sweep(rig, DEFAULT_PLAN, SimulationConfig()))


def pytest_collection_modifyitems(config, items):
    """Schedule the long tests first and keep ``--dist loadgroup`` working.

    * Tests marked ``slow`` (about 3-20 s each) come first, in their order: pytest-xdist hands
      out tests in collection order, so a long test collected last kept one core busy alone at
      the end of the run.
    * pytest-xdist 3.8 marks a grouped test by appending ``@group`` to ``item._nodeid``, which
      pytest 9 no longer reads (the node's id is ``_id``), so every group was split over both
      workers and its session fixture computed twice. Here the suffix is set where this pytest
      reads it (measured: the worn-joint diagnosis of test_diagnose_script ran once per worker
      before)."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)  # stable: order kept within
    if not getattr(config.option, "loadgroup", False):  # set by xdist in its workers
        return
    for item in items:
        names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                        for m in item.iter_markers("xdist_group")})
        if names and "@" not in item.nodeid:
            new = f"{item.nodeid}@{'_'.join(names)}"
            try:
                from _pytest.nodeid import coerce_node_id  # pytest >= 9
            except ImportError:  # pytest 8: xdist's own suffix works
                continue
            item._id = coerce_node_id(new)


def note_words(notes) -> list[str]:
    """Notes (the reader's, the diagnosis's) in the words the user reads (present.notes.note_text)."""
    from jointrig.present.notes import note_text

    return [note_text(n) for n in notes]
