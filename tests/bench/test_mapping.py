"""bench mapping: anchors drawn from a map, the summary's NEES band and counts (the drives themselves are slow)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from agvnav.bench import mapping as bm
from agvnav.mapping import BaselineAnchor, StartPoseAnchor, SurveyedAnchor
from agvnav.world import load_builtin_map


def test_anchors_use_the_two_farthest_reflectors_with_their_stated_errors() -> None:
    world = load_builtin_map("lab")
    a = bm._anchors(world, np.array([5.0, 2.0, 0.0]), np.random.default_rng(0))
    s, b, p = a["surveyed2"], a["baseline"], a["start_pose"]
    assert isinstance(s, SurveyedAnchor) and isinstance(b, BaselineAnchor) and isinstance(p, StartPoseAnchor)
    assert a["none"] is None
    i, j = (world.reflector_ids.index(k) for k in s.ids)
    true = float(np.hypot(*(world.reflector_xy[i] - world.reflector_xy[j])))
    assert true == pytest.approx(max(np.hypot(*(world.reflector_xy[m] - world.reflector_xy[n]))
                                     for m in range(9) for n in range(9)))
    assert abs(b.distance - true) < 0.005 and np.abs(s.xy - world.reflector_xy[[i, j]]).max() < 0.005


def test_summary_pools_seeds_and_bands_nees_by_chi_square() -> None:
    rows = [{"hall": "lab", "seed": s, "anchor": "baseline", "reflectors_true": 9, "reflectors_seen": 9,
             "reflectors_found": 9,
             "spurious_created": 0, "map_rms_m": 0.001, "map_max_m": 0.002 + s * 1e-3, "nees_mean": 2.0 + s,
             "nees_joint": 1.0 + s, "nees_sum_sq": 18.0, "nees_n": 9,
             "runtime_s": 1.0, "positioning_ratio": 1.1} for s in range(2)]
    rows += [{"hall": "lab", "seed": s, "anchor": "none", "reflectors_true": 9, "reflectors_found": "unobservable"}
             for s in range(2)]
    out = bm._summary(rows)
    base = next(r for r in out if r["anchor"] == "baseline")
    assert base["reflectors_found"] == 18 and base["map_max_m"] == pytest.approx(0.003)
    assert base["nees_mean"] == pytest.approx(2.5) and base["nees_joint"] == pytest.approx(1.5)
    # independent reflectors (sum of squared weights 2n): the marginal band is chi2(2n)/n, as the joint's
    for key in ("nees_band", "nees_joint_band"):
        lo, hi = (float(v) for v in base[key].split("-"))
        assert lo == pytest.approx(chi2.ppf(0.025, 36) / 18, abs=0.01)
        assert hi == pytest.approx(chi2.ppf(0.975, 36) / 18, abs=0.01)
    assert next(r for r in out if r["anchor"] == "none")["reflectors_found"] == "unobservable"


@pytest.mark.slow
def test_lab_record_finds_every_reflector() -> None:
    rows = bm._record("lab", 0, with_positioning=False)
    assert {r["anchor"] for r in rows} == {"surveyed2", "baseline", "start_pose", "none"}
    base = next(r for r in rows if r["anchor"] == "baseline")
    assert base["reflectors_found"] == 9 and base["spurious_created"] == 0


def test_calibrated_scale_is_the_taped_run_over_the_odometry() -> None:
    """A 6 m straight then a turn: the scale is the taped distance over the odometry's, with the tape's and
    the slip's std; a drive that turns at once gets the uncalibrated 1 +- 0.2 %."""
    from agvnav.logs import RecordedLog

    n = 800
    inc = np.zeros((n, 3))
    inc[:, 0] = 0.01
    inc[600:, 1] = 0.01  # turns after 6 m
    t = np.arange(n + 1) * 0.05
    x = 1.003 * np.concatenate([[0.0], np.cumsum(inc[:, 0])])
    truth = np.column_stack([x, np.zeros(n + 1), np.zeros(n + 1)])
    log = RecordedLog(t, inc, np.zeros(0), np.zeros(0), np.zeros(0), {}, truth=truth)
    scale, std, length = bm.calibrated_scale(log, np.random.default_rng(0))
    assert length == pytest.approx(6.0, abs=0.02)
    assert scale == pytest.approx(1.003, abs=3 * 0.001 * np.sqrt(2) / 6.0)
    assert std == pytest.approx(np.hypot(0.001 * np.sqrt(2), 0.01 * np.sqrt(length)) / length)
    inc[:, 1] = 0.01
    turning = RecordedLog(t, inc, np.zeros(0), np.zeros(0), np.zeros(0), {}, truth=truth)
    assert bm.calibrated_scale(turning, np.random.default_rng(0)) == (1.0, 0.002, 0.0)


def test_nees_statistics_of_correlated_reflectors_against_a_monte_carlo() -> None:
    """Reflectors sharing one error (an anchor 1 mm off moves all of them): draws from the joint covariance
    give a joint NEES per reflector of 2 and marginal means whose spread matches marginal_band, a
    Welch-Satterthwaite approximation (a chi2(2n)/n band would hold far fewer than 95 %)."""
    rng = np.random.default_rng(1)
    n = 6
    C = np.eye(2 * n) * 0.2e-6 + np.kron(np.ones((n, n)), np.eye(2)) * 1e-6  # shared 1 mm, own 0.45 mm
    L = np.linalg.cholesky(C)
    marg, joint = [], []
    stats = {}
    for _ in range(4000):
        e = (L @ rng.normal(size=2 * n)).reshape(n, 2)
        stats = bm.nees_statistics(e, C, np.arange(n))
        joint.append(stats["nees_joint"])
        marg.append(np.mean([v @ np.linalg.solve(C[2 * j:2 * j + 2, 2 * j:2 * j + 2], v) for j, v in enumerate(e)]))
    assert np.mean(joint) == pytest.approx(2.0, rel=0.03) and np.mean(marg) == pytest.approx(2.0, rel=0.05)
    lo, hi = bm.marginal_band(2.0 * n, stats["nees_sum_sq"], n)
    inside = np.mean((np.array(marg) > lo) & (np.array(marg) < hi))
    assert 0.93 < inside < 0.98  # Welch-Satterthwaite is approximate: 97.4 % here
    naive = np.mean((np.array(marg) > chi2.ppf(0.025, 2 * n) / n) & (np.array(marg) < chi2.ppf(0.975, 2 * n) / n))
    assert naive < 0.85
    jlo, jhi = bm.joint_band(n)
    assert 0.93 < np.mean((np.array(joint) > jlo) & (np.array(joint) < jhi)) < 0.97


def test_positioning_replays_tell_the_ekf_only_the_maps_own_survey_std(monkeypatch: pytest.MonkeyPatch) -> None:
    """The exact map is replayed as exact (map_std 0, not the EKF's 1 mm default): the positioning ratio then
    compares the maps alone, each with its own stated survey std."""
    seen: list[dict] = []

    def fake(settings: dict, world: object, method: str) -> object:
        seen.append(settings)
        raise RuntimeError("stop")

    monkeypatch.setattr(bm, "estimator_from_settings", fake)
    from agvnav.logs import RecordedLog

    log = RecordedLog(np.arange(3) * 0.05, np.zeros((2, 3)), np.zeros(0), np.zeros(0), np.zeros(0),
                      {"map_std_m": 0.005}, truth=np.zeros((3, 3)))
    with pytest.raises(RuntimeError, match="stop"):
        bm._positioning_rms(log, load_builtin_map("lab"))
    assert seen[0]["map_std_m"] == 0.0 and log.settings["map_std_m"] == 0.005


def test_frame_error_is_the_rms_move_of_the_fitted_similarity() -> None:
    """A mapped map off by a 1 mrad rotation and a (1, -2) mm shift: the similarity fitted onto the truth moves
    it back exactly, its RMS move is the frame error, and the moved map is the true one."""
    from agvnav.mapping.anchors import apply_similarity, fit_similarity

    world = load_builtin_map("lab")
    true = world.reflector_xy
    off = apply_similarity(np.array([np.cos(1e-3), np.sin(1e-3), 0.001, -0.002]), true)
    T = fit_similarity(off, true)
    expected = float(np.sqrt(np.mean(np.sum((off - true) ** 2, axis=1))))
    assert bm._frame_error(off, T) == pytest.approx(expected, rel=1e-9)
    mapped = bm._moved(world, np.array([np.cos(1e-3), np.sin(1e-3), 0.001, -0.002]))
    np.testing.assert_allclose(bm._moved(mapped, T).reflector_xy, true, atol=1e-12)


def test_anchor_chi2_is_the_drawn_error_over_the_stated_std_and_the_summary_sums_it() -> None:
    """A surveyed pair 1 mm (std 1 mm) off in x each gives chi2 2 with 4 dof; a tape 2 mm (std 1 mm) long gives 4
    with 1 dof; the start pose none. The summary sums the seeds' with the chi-square band of the summed dof."""
    world = load_builtin_map("lab")
    xy, ids = world.reflector_xy, world.reflector_ids
    s = SurveyedAnchor((ids[0], ids[1]), xy[:2] + [[0.001, 0.0], [-0.001, 0.0]], np.array([0.001, 0.001]))
    d = float(np.hypot(*(xy[1] - xy[0])))
    b = BaselineAnchor(tuple((xy[0] + 0.1).tolist()), tuple((xy[1] - 0.1).tolist()), d + 0.002, 0.001)
    assert bm._anchor_chi2(s, world) == {"anchor_chi2": pytest.approx(2.0), "anchor_dof": 4}
    assert bm._anchor_chi2(b, world) == {"anchor_chi2": pytest.approx(4.0), "anchor_dof": 1}
    assert bm._anchor_chi2(StartPoseAnchor(), world)["anchor_chi2"] is None
    rows = [{"hall": "lab", "seed": k, "anchor": "surveyed2", "reflectors_true": 9, "reflectors_seen": 9,
             "reflectors_found": 9, "spurious_created": 0, "map_rms_m": 0.001, "map_max_m": 0.002,
             "map_rms_predicted_m": 0.001 * (k + 1), "nees_mean": 2.0, "nees_joint": 2.0, "nees_sum_sq": 18.0,
             "nees_n": 9, "runtime_s": 1.0, "anchor_chi2": 3.0 + k, "anchor_dof": 4} for k in range(2)]
    out = bm._summary(rows)[0]
    assert out["anchor_chi2"] == pytest.approx(7.0)
    assert out["anchor_chi2_band"] == f"{chi2.ppf(0.025, 8):.2f}-{chi2.ppf(0.975, 8):.2f}"
    assert out["map_rms_predicted_m"] == pytest.approx(np.sqrt((0.001 ** 2 + 0.002 ** 2) / 2))
