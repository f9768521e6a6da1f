"""The main job end to end: JSON schema and a readable rerun recording with the expected entities."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import rerun as rr

ROOT = Path(__file__).resolve().parent.parent

from jointrig.commands import run_sweep  # noqa: E402

from jointrig.present.recording import expected_entities, run_label  # noqa: E402

# One worker runs this module: its session-scoped fixture is computed once (pytest-xdist
# --dist loadgroup), not once per worker.
pytestmark = pytest.mark.xdist_group("run_sweep_script")


@pytest.fixture(scope="session")  # once per worker, even when xdist interleaves other modules
def outputs(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    argv = ["--omegas", "10", "45", "80", "--amplitudes", "400", "4000", "--json", str(out / "r.json"),
            "--rrd", str(out / "r.rrd"), "--store", str(out / "store"), "-q"]
    assert run_sweep.main(argv) == 0
    return out


def test_json_schema_and_accuracy(outputs):
    data = json.loads((outputs / "r.json").read_text())
    assert set(data["parameters"]) == {"Je_kgm2", "c_Nms_per_rad", "k_Nm_per_rad", "gamma_Nm_per_rad3"}
    for name, row in data["parameters"].items():
        assert set(row) == {"true", "identified", "rel_error", "std_error"}
        assert abs(row["rel_error"]) < 1e-4, name  # acceptance: noise-free rig data within 1e-4
    assert data["success"] is True and data["form"] == "equivalent"
    assert len(data["sweep"]["runs"]) == 6


def test_recording_is_written_readable_and_complete(outputs):
    rrd = outputs / "r.rrd"
    store = rr.chunk.RrdReader(rrd).store()
    entities = set(store.schema().entity_paths())
    runs = json.loads((outputs / "r.json").read_text())["sweep"]["runs"]
    want = expected_entities([run_label(r["omega_rad_s"], r["amplitude_Nm"]) for r in runs])
    assert "/runs/w45_M4000/phi_rad" in want and "/phase_portrait/w10_M400" in want
    assert want <= entities, sorted(want - entities)
    assert any(e.startswith("/frf/") for e in entities)
    # The blueprint: the identified law first, then named views; every origin holds data.
    from conftest import blueprint_views

    names, origins = blueprint_views(rrd)
    assert {"Identified law", "Frequency response", "Runs", "Phase portraits",
                                "Harmonic spectra"} <= set(names)
    assert "10 rad/s, 400 N m: phi [rad], torque [N m] (timeline t_s)" in names
    for origin in origins:
        assert any(e == "/" + origin or e.startswith("/" + origin + "/") for e in entities), origin
    assert len(origins) == 2 + 2 + 3 * len(runs)
    assert not list(outputs.glob(".*.tmp"))  # written atomically
    beside = Path(sys.executable).with_name("rerun")  # the CLI ships with rerun-sdk, in the same bin/
    cli = str(beside) if beside.exists() else shutil.which("rerun")
    if cli:  # `rerun rrd verify` decodes every chunk
        subprocess.run([cli, "rrd", "verify", str(rrd)], check=True, capture_output=True)


def test_noisy_multisine_job_reports_standard_errors_and_line_levels(tmp_path, capsys):
    out = tmp_path / "ms.json"
    assert run_sweep.main(["--excitation", "multisine", "--noise-db", "40", "--periods", "4", "--no-rrd",
                           "--json", str(out), "-q"]) == 0
    data = json.loads(out.read_text())
    assert data["excitation"] == "multisine" and data["noise_db"] == 40
    assert data["estimator"] == "errors-in-variables maximum likelihood"
    for name, row in data["parameters"].items():
        # Within 4 of its own standard errors of the truth (a 6e-5 chance per parameter if the
        # errors are right; bench_identification.py measures their coverage).
        assert abs(row["identified"] - row["true"]) < 4 * row["std_error"], name
    levels = data["sweep"]["runs"][0]["line_levels_rad2"]
    # 40 dB of the angle's RMS spread over 12 excited lines: ~15 dB per line above the noise.
    assert levels["noise"] > 0 and levels["excited"] > 10 * levels["noise"]
    assert "standard errors from the truth" in capsys.readouterr().out
