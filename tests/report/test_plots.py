import itertools
import subprocess
import sys

import numpy as np
import pytest

from agvnav.report import plot_errors, plot_map, plot_positioning_histogram, write_plots


def _png(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    return data


def _series(n=200):
    t = np.linspace(0.0, 20.0, n)
    x = 0.2 * t
    zeros = np.zeros(n)
    return {
        "t": t,
        "x": x,
        "y": zeros,
        "psi": zeros,
        "x_tracked": x + 1.0,
        "y_tracked": 0.1 * np.exp(-t),
        "est_x": x + 0.001,
        "est_y": 0.002 * np.sin(t),
        "est_psi": zeros,
        "est_valid": np.ones(n),
        "lateral_error": 0.1 * np.exp(-t),
        "heading_error": -0.1 * t * np.exp(-t),
    }


def test_write_plots_creates_three_pngs(tmp_path):
    s = _series()
    path_xy = np.column_stack([np.linspace(1, 5, 50), np.zeros(50)])
    refl = np.array([[0.0, 3.0], [6.0, 3.0], [3.0, -3.0]])
    walls = np.array([[[0.0, -4.0], [6.0, -4.0]]])
    files = write_plots(s, path_xy, refl, walls, tmp_path / "out", transient_end_s=3.0, title="t")
    assert [f.name for f in files] == ["map.png", "errors.png", "positioning_histogram.png"]
    for f in files:
        _png(f)


def test_single_plots_and_empty_histogram(tmp_path):
    s = _series(50)
    _png(plot_errors(s["t"], s["lateral_error"], s["heading_error"], tmp_path / "e.png"))
    xy = np.column_stack([s["x"], s["y"]])
    _png(plot_map(xy, xy, np.zeros((0, 2)), np.zeros((0, 2, 2)), tmp_path / "m.png"))
    _png(plot_positioning_histogram(np.array([np.nan]), tmp_path / "h.png"))


def test_math_packages_do_not_import_matplotlib():
    code = "import sys, agvnav.sim, agvnav.report, agvnav.world.scenario; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_figures_prepared_ahead_give_the_same_files(tmp_path):
    from agvnav.report import plots

    s = _series()
    path_xy = np.column_stack([np.linspace(1, 5, 50), np.zeros(50)])
    refl = np.array([[0.0, 3.0], [6.0, 3.0], [3.0, -3.0]])
    walls = np.array([[[0.0, -4.0], [6.0, -4.0]], [[0.0, 4.0], [6.0, 4.0]]])
    plain = write_plots(s, path_xy, refl, walls, tmp_path / "plain", transient_end_s=3.0, title="t")
    plots.prepare(plots.RUN_PLOTS)
    assert set(plots._READY) == set(plots.RUN_PLOTS)
    ahead = write_plots(s, path_xy, refl, walls, tmp_path / "ahead", transient_end_s=3.0, title="t")
    assert not plots._READY  # each prepared figure is used once
    assert [_png(a) for a in ahead] == [_png(p) for p in plain]
    with pytest.raises(ValueError, match="speed"):
        plots.prepare(["map", "speed"])
    assert not plots._READY  # nothing made for a refused request


def test_error_labels_fit_the_vehicle():
    # issue 29: every vehicle's plots used the tricycle's eps_c / xi_r names
    from agvnav.report.plots import error_labels

    one = np.zeros(3)
    assert error_labels({"xi_r": one, "point_offset": np.ones(3)}) == (
        "lateral error ε_c of C [mm]", "wheel heading error ξ_r [deg]")
    assert error_labels({"xi_r": one, "point_offset": one})[0] == "lateral error ε_o of O [mm]"
    assert "guided point" in error_labels({"xi_r": one, "point_offset": np.array([0.0, 1.0, 0.0])})[0]
    mecanum = error_labels({"v_y": one})
    differential = error_labels({"v_lateral_cmd": one})
    assert "ξ" not in mecanum[1] + differential[1] and "wheel" not in mecanum[1] + differential[1]
    assert "yaw offset" in mecanum[1] and "yaw offset" not in differential[1]


def test_event_spans_show_faults_guard_fields_and_stations():
    from agvnav.report.plots import event_spans

    t = np.arange(8) * 1.0
    series = {"fault__0_blind": np.array([0, 1, 1, 1, 0, 0, 0, 0.0]),
              "est_status": np.array([1, 1, 2, 2, 1, 1, 1, 1.0]),
              "guard_level": np.array([0, 0, 1, 1, 1, 0, 0, 0.0]),
              "reaction_level": np.array([0, 0, 0, 0, 0, 1, 2, 0.0]),
              "dwelling": np.zeros(8)}
    spans = {label: w for label, _c, w in event_spans(t, series)}
    assert spans == {"fault 0 blind": [(1.0, 4.0)], "dead reckoning": [(2.0, 4.0)], "guard: slow": [(2.0, 5.0)],
                     "field: slow": [(5.0, 6.0)], "field: stop": [(6.0, 7.0)]}


def test_overlapping_event_kinds_get_strips_of_their_own():
    """fault_blackout: the 4-16 s blackout, dead reckoning and the guard's slow window overlap in time; drawn
    full height their colours mixed and the fault vanished under the others (issue 29). Each kind now has its
    own strip of the speed axes: the strips tile the height without overlapping, the fault's on top."""
    from agvnav.report.plots import event_spans, event_strips

    t = np.arange(20) * 1.0
    series = {"fault__0_blind": (t >= 4) & (t < 16), "est_status": np.where((t >= 5) & (t < 16), 2.0, 1.0),
              "guard_level": ((t >= 5) & (t < 17)).astype(float)}
    strips = event_strips(event_spans(t, {k: np.asarray(v, dtype=float) for k, v in series.items()}))
    assert [s[0] for s in strips] == ["fault 0 blind", "dead reckoning", "guard: slow"]
    bounds = sorted(s[3] for s in strips)
    assert bounds[0][0] == 0.0 and bounds[-1][1] == 1.0 and strips[0][3][1] == 1.0
    assert all(a[1] == pytest.approx(b[0]) for a, b in itertools.pairwise(bounds))
    assert event_strips([("x", "k", [(0.0, 1.0)])])[0][3] == (0.0, 1.0)  # one kind alone: full height
