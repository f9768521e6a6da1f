"""The unknown-law and Silverbox recordings carry their blueprints, and every view's origin holds
data the recording has (read back from the file). Synthetic curves: the layout is under test here,
not the numbers (those are tested with the commands' outputs)."""

import numpy as np
import rerun as rr

from conftest import blueprint_views
from jointrig.present.recording import log_parameter_table, log_restoring_band, log_silverbox, open_recording
from jointrig.present.recording import unknown_law_blueprint


def _paths(rrd):
    return {str(p) for p in rr.chunk.RrdReader(str(rrd)).store().schema().entity_paths()}


def _origins_hold_data(rrd, origins):
    paths = _paths(rrd)
    return [o for o in origins if not any(p == "/" + o or p.startswith("/" + o + "/") for p in paths)]


def test_unknown_law_recording_has_its_layout(tmp_path):
    phi = np.linspace(-0.3, 0.3, 41)
    g = 2000 * phi
    rrd = tmp_path / "u.rrd"
    with open_recording(rrd) as rec:
        rec.send_blueprint(unknown_law_blueprint(True))
        log_restoring_band(rec, phi, g, g - 5, g + 5, None, {"true_Nm": g, "best_quintic_Nm": g})
        rate = np.linspace(-10, 10, 11)
        log_restoring_band(rec, rate, 100 * rate, 100 * rate - 5, 100 * rate + 5, None, {"true_Nm": 100 * rate},
                           entity="damping_force", index="rate_urad_s")
        log_parameter_table(rec, "hat fit")
    names, origins = blueprint_views(rrd)
    assert any(n.startswith("restoring torque g(phi) [N m]") for n in names)
    assert any(n.startswith("damping torque f(phi') [N m]") for n in names)
    assert sorted(origins) == ["damping_force", "parameters", "restoring_force"]
    assert _origins_hold_data(rrd, origins) == []


def test_silverbox_recording_has_its_layout(tmp_path):
    y = np.sin(np.arange(1000) / 50.0)
    rrd = tmp_path / "s.rrd"
    with open_recording(rrd) as rec:
        log_silverbox(rec, 610.35, y, 1.01 * y, 1.001 * y, np.ones(50), 0.1 * np.ones(50), "| model | mV |")
    names, origins = blueprint_views(rrd)
    assert {"Arrow test", "Residual spectra", "RMS error [mV] on the arrow"} <= set(names)
    assert sorted(origins) == ["arrow", "arrow", "estimation/residual_spectrum_extended_V",
                               "estimation/residual_spectrum_nominal_V", "table"]
    assert _origins_hold_data(rrd, origins) == []
    assert {"/arrow/measured_V", "/arrow/nominal_error_V", "/arrow/extended_error_V"} <= _paths(rrd)
