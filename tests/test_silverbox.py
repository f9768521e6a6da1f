"""Issue: the Silverbox benchmark on the real files (reader checks, the whole path and its figure)."""

import json

import numpy as np
import pytest

from jointrig.measured.silverbox import DEFAULT_DIR, SilverboxError, load_silverbox

HAVE_DATA = (DEFAULT_DIR / "SNLS80mV.csv").is_file()
needs_data = pytest.mark.skipif(not HAVE_DATA, reason=f"Silverbox data not at {DEFAULT_DIR}")


@needs_data
def test_reader_locates_the_documented_layout():
    d = load_silverbox()
    assert d.u_V.shape == d.y_V.shape == (131072,)
    # SOURCE.md: first block near 40600, blocks ~8692 apart (a few samples off the stride).
    starts = np.array(d.block_starts)
    assert len(starts) == 10 and abs(starts[0] - 40600) < 30
    assert np.all(np.abs(np.diff(starts) - 8692) < 20)
    assert 5e-3 < d.u_offset_V < 7.5e-3 and 0.5e-3 < d.y_offset_V < 1.5e-3  # ~6.2 mV and ~1.0 mV
    u, y = d.estimation_periods()
    assert u.shape == y.shape == (10, 8192)
    U = np.abs(np.fft.rfft(u, axis=-1))
    # odd lines 1..2683 excited: 40 dB above the even lines
    assert np.mean(U[:, 1:2684:2] ** 2) > 1e4 * np.mean(U[:, 2:2684:2] ** 2)
    _, _, scored = d.arrow("full")
    assert (scored.start, scored.stop) == (150, 40575)


def test_reader_errors_name_the_file(tmp_path):
    with pytest.raises(SilverboxError, match="no such file"):
        load_silverbox(tmp_path)
    (tmp_path / "SNLS80mV.csv").write_text('"A","B",\n1,2,\n')
    with pytest.raises(SilverboxError, match=r"SNLS80mV.csv: columns \['A', 'B'\]"):
        load_silverbox(tmp_path)
    (tmp_path / "SNLS80mV.csv").write_text('"V1","V2",\n' + "0.0,0.0,\n" * 100)
    with pytest.raises(SilverboxError, match="too short"):
        load_silverbox(tmp_path)


@needs_data
@pytest.mark.slow
def test_whole_path_on_the_real_files(tmp_path):
    from jointrig.commands import silverbox

    out = tmp_path / "sb.json"
    assert silverbox.main(["-q", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    rms = r["rms_mV"]
    # Acceptance: nominal Duffing <= 1.2 mV on the full arrow; extended <= 0.5 mV with <= 12 parameters.
    assert rms["nominal"]["full"] <= 1.2
    assert rms["extended"]["full"] <= 0.5 and r["n_parameters"] <= 12
    # The extension was chosen on estimation data and another excitation of the same circuit
    # (the Schroeder multisine; issue 13); it must also pay on the test data and be no worse
    # there.
    assert rms["extended"]["full"] < rms["nominal"]["full"]
    assert rms["extended"]["no_extrapolation"] <= rms["nominal"]["no_extrapolation"]
    sch = r["schroeder_rms_mV"]
    assert sch["extended"] <= sch["nominal"]
    # cubic damping fits the estimation multisine but not the circuit: measured 24% worse on
    # the Schroeder multisine, so it is not adopted
    rejected = {s["effect"] for s in r["selection"] if not s["kept"]}
    assert "cubic_damping" in rejected and "cubic_damping" not in r["extended_effects"]
    # MuJoCo rig (RK4, 8 steps/sample) vs scipy LSODA (rtol 1e-9): both ~1e-6 relative on a 0.2 V
    # signal over 4096 samples; 5 uV is 1% of the model error being measured.
    assert r["mujoco_vs_scipy_max_abs_V"] < 5e-6
    assert set(r["rms_mV"]["nominal"]) == {"full", "no_extrapolation"}
