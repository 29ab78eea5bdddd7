"""The seed-defined figures (issue 13) on synthetic signals whose answer is known."""

import math

import numpy as np
import pytest

from agvnav.sim.metrics import (
    guidance_figures,
    lateral_error_statistics,
    max_abs_from,
    settling_distance,
    tracer_samples,
    transient_end_index,
)


def _decay_with_bump(bump_m=0.014, n=2001, ds=0.0025):
    """C rolls 5 m: 110 mm decaying over 0.25 m, then a 14 mm bump 1 m into a straight that starts at 2 m."""
    s = np.arange(n) * ds
    e = 0.110 * np.exp(-s / 0.25)
    e = e + bump_m * np.exp(-(((s - 3.0) / 0.05) ** 2))
    return s, e


def test_decaying_error_with_a_later_bump_reports_the_bump():
    s, e = _decay_with_bump()
    g = guidance_figures(s, s, e, np.zeros_like(e), straight_start_s=2.0, after_m=0.5)
    assert g.max_abs_eps_c_after_m == pytest.approx(0.014, rel=1e-3)
    # a bigger bump gives a bigger figure: the metric follows the signal, not a band
    _, e2 = _decay_with_bump(bump_m=0.030)
    g2 = guidance_figures(s, s, e2, np.zeros_like(e2), straight_start_s=2.0, after_m=0.5)
    assert g2.max_abs_eps_c_after_m == pytest.approx(0.030, rel=1e-3)
    # the old band reading (first entry into 10 %) sees 11 mm whatever the bump
    k = transient_end_index(e)
    assert abs(e[k]) == pytest.approx(0.011, abs=3e-4)


def test_straight_reading_includes_the_junction():
    s, e = _decay_with_bump(bump_m=0.0)
    e = e + 0.02 * ((s >= 2.0) & (s < 2.2))  # junction disturbance
    g = guidance_figures(s, s, e, np.zeros_like(e), straight_start_s=2.0, after_m=0.5)
    assert g.max_abs_eps_c_straight_m == pytest.approx(0.02, rel=1e-2)
    assert g.max_abs_eps_c_after_m < 1e-4


def test_settling_distance_enters_and_stays():
    s, e = _decay_with_bump()  # 22 mm band: entered at 0.25 ln 5 m, the 14 mm bump stays inside
    g = guidance_figures(s, s, e, np.zeros_like(e), straight_start_s=2.0)
    assert g.settling_band_m == pytest.approx(0.022)
    assert g.settling_distance_m == pytest.approx(0.25 * math.log(5.0), abs=0.0025)
    # a 30 mm bump leaves the band: settling moves past the bump
    _, e2 = _decay_with_bump(bump_m=0.030)
    d = settling_distance(e2, s, 0.022)
    assert d is not None and 3.0 < d < 3.1
    assert settling_distance(np.full(5, 0.1), np.arange(5.0), 0.01) is None
    assert settling_distance(np.zeros(5), np.arange(5.0), 0.01) == 0.0


def test_wheel_heading_figure_read_on_the_same_window():
    s = np.linspace(0.0, 5.0, 501)
    xr = np.where(s < 2.4, 0.3, math.radians(2.0) * np.sin(4 * s))
    g = guidance_figures(s, s, np.zeros_like(s) + 0.11, xr, straight_start_s=2.0)
    assert g.max_abs_xi_r_after_rad == pytest.approx(math.radians(2.0), rel=1e-3)


def test_tracer_samples_one_per_second():
    t = np.arange(0.0, 10.0 + 1e-9, 0.05)
    k = tracer_samples(t)
    np.testing.assert_allclose(t[k], np.arange(11.0), atol=1e-9)
    k = tracer_samples(t, phase=0.52)
    np.testing.assert_allclose(t[k], np.arange(10) + 0.5, atol=1e-9)  # nearest sample to x.52 is x.50
    with pytest.raises(ValueError, match="phase"):
        tracer_samples(t, phase=1.0)
    with pytest.raises(ValueError, match="increasing"):
        tracer_samples(t[::-1])


def test_both_readings_of_the_std():
    # e_lat alternates +c, -c each second: |e| is constant (std 0), the signed std is c
    t = np.arange(0.0, 20.0, 0.05)
    e = 0.01 * np.where(np.floor(t + 1e-9) % 2 == 0, 1.0, -1.0)
    st = lateral_error_statistics(t, e)
    assert st is not None and st.samples == 20
    assert st.mean_abs_m == pytest.approx(0.01)
    assert st.std_abs_m == pytest.approx(0.0, abs=1e-12)
    assert st.std_signed_m == pytest.approx(0.01)
    assert st.max_abs_m == pytest.approx(0.01)


def test_tracer_rate_hides_short_spikes_and_skips_invalid():
    t = np.arange(0.0, 10.0, 0.05)
    e = np.full_like(t, 0.005)
    e[np.isclose(t, 3.5)] = 0.05  # between two marks: the seed's tracer never saw it
    st = lateral_error_statistics(t, e)
    assert st is not None and st.max_abs_m == pytest.approx(0.005)
    valid = t >= 5.0 - 1e-9
    e2 = np.where(valid, 0.002, 0.5)
    st2 = lateral_error_statistics(t, e2, valid)
    assert st2 is not None and st2.samples == 5 and st2.max_abs_m == pytest.approx(0.002)
    assert lateral_error_statistics(t, e, np.zeros_like(t, dtype=bool)) is None


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="same shape"):
        max_abs_from(np.zeros(3), np.zeros(4), 0.0)
    with pytest.raises(ValueError, match="band"):
        settling_distance(np.zeros(3), np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="after_m"):
        guidance_figures(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), 1.0, after_m=-1.0)
    assert max_abs_from(np.ones(3), np.arange(3.0), 5.0) is None
