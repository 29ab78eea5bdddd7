"""agvnav._jit: lazy kernels that run compiled (numba) or interpreted with the same numbers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from agvnav import _jit
from agvnav.geometry import wrap_angle
from agvnav.geometry.angles import wrap_angle_kernel, wrap_angle_scalar
from agvnav.positioning import _fast
from agvnav.positioning._integrity_fast import _information_sums, best_triple
from agvnav.positioning.gating import BearingIndex, GateSpec, near_rows
from agvnav.positioning.integrity import _fde_statistics, _window_tally
from agvnav.sensors import beam
from agvnav.vehicles.tricycle import hermite_poses

pytestmark = pytest.mark.usefixtures("restore_jit_mode")


def _kernel_outputs() -> list[bytes | str]:
    """Every kernel of the closed loop on fixed inputs (nested kernels included: line_of_sight calls _hits_*)."""
    rng = np.random.default_rng(7)
    n, k = 9, 40
    rx, ry, r = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), rng.uniform(0.02, 0.3, n)
    grid = np.linspace(0.0, 0.2, k)
    pose = np.column_stack([np.linspace(0, 0.3, k), rng.uniform(-0.1, 0.1, k), np.linspace(-3.2, 3.3, k)])
    head = (0.2, -0.1, 0.3, 2 * math.pi * 8.0)
    out: list[bytes | str] = []
    for direction in (1, -1):
        out += [a.tobytes() for a in beam.grid_crossings(grid, pose, rx, ry, r, *head, direction)]
        refl = rng.integers(0, n, k)
        off, hx, hy, d = beam.offsets_at(grid, pose, rx[refl], ry[refl], r[refl], *head, direction)
        out += [a.tobytes() for a in (off, hx, hy, d)]
        w0x, w0y, wvx, wvy = rng.uniform(-5, 5, (4, 12))
        seen = beam.line_of_sight(refl.astype(np.int64), hx, hy, d, rx, ry, r, w0x, w0y, wvx, wvy, 0.1, 6.0)
        out.append(np.asarray(seen).tobytes())
    raw = np.concatenate([rng.uniform(-30, 30, 20), [math.pi, -math.pi, 3 * math.pi, 0.0, -0.0]])
    f, worst = beam.wrapped_offsets(raw)
    assert worst == np.abs(f).max() and np.array_equal(f, wrap_angle(raw))  # the wrap it stands for, exactly
    out += [f.tobytes(), float(worst).hex()]
    f_nan, worst_nan = beam.wrapped_offsets(np.array([1.0, math.nan, 2.0, math.inf]))
    assert math.isnan(worst_nan) and np.isnan(f_nan[[1, 3]]).all()
    rx2, ry2 = rng.uniform(-10, 10, 64), rng.uniform(-10, 10, 64)
    r2 = rng.uniform(0.02, 0.1, 64) ** 2
    for beam_dir in rng.uniform(-7, 7, 5):
        rows = near_rows(rx2, ry2, r2, 0.5 * math.pi * np.sqrt(r2), 0.3, -0.2, beam_dir, 1e-4, 1e-3, 8.0)
        out.append(np.asarray(rows).tobytes())
    out.append(np.asarray(hermite_poses(rng.normal(size=(4, 3)), 0.0, 0.05, np.linspace(-0.01, 0.06, 9))).tobytes())
    return out


def test_interpreted_and_compiled_kernels_agree_bit_for_bit() -> None:
    _jit.set_compiled(False)
    interpreted = _kernel_outputs()
    _jit.set_compiled(True)
    compiled = _kernel_outputs()
    assert interpreted == compiled  # exact: IEEE double, no fastmath, the same math functions


def _random_outputs() -> dict[str, list[bytes]]:
    """Every kernel on 1e5 random inputs (offsets over a 40 m hall, any heading): each output's bytes."""
    rng = np.random.default_rng(11)
    c = 50_000  # per direction: 1e5 calls of offset_one through offsets_at
    t = rng.uniform(0.0, 500.0, c)
    pose = np.column_stack([rng.uniform(-20, 20, c), rng.uniform(-20, 20, c), rng.uniform(-7, 7, c)])
    rx, ry, r = rng.uniform(-20, 20, c), rng.uniform(-20, 20, c), rng.uniform(0.01, 0.5, c)
    out: dict[str, list[bytes]] = {}
    for direction in (1, -1):
        head = (0.2, -0.1, 0.3, direction * 2 * math.pi * 8.0, direction)
        out[f"offsets_at {direction}"] = [a.tobytes() for a in beam.offsets_at(t, pose, rx, ry, r, *head)]
        grid, gpose = np.sort(t[:400]) / 100.0, pose[:400]
        out[f"grid_crossings {direction}"] = [
            a.tobytes() for a in beam.grid_crossings(grid, gpose, rx[:60], ry[:60], r[:60], *head)
        ]
        interval, refl, f_lo, f_hi = beam.grid_crossings(grid, gpose, rx[:60], ry[:60], r[:60], *head)
        start = beam.chord_brackets(grid, interval, f_lo, f_hi, refl, rx[:60], ry[:60], r[:60])
        out[f"chord_brackets {direction}"] = [a.tobytes() for a in start]
        lo, hi, slope, t1, trx, try_, tr, _ = start
        tpose = np.column_stack([lo * 0.1, hi * 0.2, lo])  # any finite poses at the chord instants
        for tol in (1e-10, 10.0):  # not converged (the next instants) and converged (the same ones)
            done, *arrays = beam.chord_step(t1, tpose, trx, try_, tr, *head[:4], direction, slope, lo, hi, tol)
            out[f"chord_step {direction} {tol}"] = [str(bool(done)).encode(), *(a.tobytes() for a in arrays)]
    from agvnav.world import load_builtin_map

    lab = load_builtin_map("lab")
    seg = lab.wall_segments
    walls = (seg[:, 0, 0].copy(), seg[:, 0, 1].copy(), seg[:, 1, 0] - seg[:, 0, 0], seg[:, 1, 1] - seg[:, 0, 1])
    lx, ly = lab.reflector_xy[:, 0].copy(), lab.reflector_xy[:, 1].copy()
    scans = []
    for k in range(400):  # scan_hermite (and _finite_poses) on random steps through the lab
        p0 = np.array([rng.uniform(2.0, 18.0), rng.uniform(2.0, 10.0), rng.uniform(-4.0, 4.0)])
        table = np.array([p0, rng.normal(0.0, 0.05, 3), p0 + rng.normal(0.0, 0.04, 3), rng.normal(0.0, 0.05, 3)])
        grid = np.linspace(0.05 * k, 0.05 * k + 0.05, 3)
        status, ts, rs = beam.scan_hermite(table, 0.05 * k, 0.05, grid, lx, ly, lab.reflector_radius, 0.3, 0.0,
                                           0.0, 2.0 * math.pi * 8.0, 1, *walls, 0.0, 30.0, 8.0, 1e-10, 2.2e-16, 6)
        scans += [str(status).encode(), ts.tobytes(), rs.tobytes()]
    out["scan_hermite"] = scans
    ts = np.round(rng.uniform(0.0, 1.0, 300), 2)  # ties: a stable sort keeps their order
    picked = beam.seen_in_order(ts, np.arange(300, dtype=np.int64), rng.uniform(size=300) < 0.7)
    out["seen_in_order"] = [a.tobytes() for a in picked]
    angles = np.concatenate([rng.uniform(-50.0, 50.0, 100_000), [math.pi, -math.pi, 3 * math.pi, 0.0, -0.0, 1e-300]])
    out["wrap_angle_kernel"] = [np.array([wrap_angle_kernel(float(a)) for a in angles[:20_000]]).tobytes()]
    f, worst = beam.wrapped_offsets(angles)
    out["wrapped_offsets"] = [f.tobytes(), float(worst).hex().encode()]
    n, k = 200, 5_000
    refl = rng.integers(0, n, k)
    hx, hy = rng.uniform(-20, 20, k), rng.uniform(-20, 20, k)
    d = np.sqrt((rx[refl] - hx) ** 2 + (ry[refl] - hy) ** 2)
    w0x, w0y, wvx, wvy = rng.uniform(-20, 20, (4, 30))
    seen = beam.line_of_sight(refl, hx, hy, d, rx[:n], ry[:n], r[:n] * 0.2, w0x, w0y, wvx, wvy, 0.1, 30.0)
    out["line_of_sight"] = [np.asarray(seen).tobytes()]
    out["near_rows"] = [
        np.asarray(near_rows(rx[:500], ry[:500], r[:500] ** 2, 0.5 * math.pi * r[:500], x, y, b, 1e-4, 1e-3, 15.0))
        .tobytes()
        for x, y, b in rng.uniform(-10, 10, (200, 3))
    ]
    out["hermite_poses"] = [
        np.asarray(hermite_poses(rng.normal(size=(4, 3)), 0.0, 0.05, rng.uniform(-0.01, 0.06, 1_000))).tobytes()
        for _ in range(100)
    ]
    spec = GateSpec(1e-8, 15.0, 10.83, 0.005, 0.09)  # grid_rows (and _visit_box) through the index
    index = BearingIndex(np.column_stack([rx[:500], ry[:500]]), r[:500] * 0.2, (0.3, 0.1, 0.2), spec)
    P = (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5)
    out["grid_rows"] = [
        np.asarray(index.candidates(float(z), (float(x), float(y), float(p)), P)).tobytes()
        for x, y, p, z in rng.uniform(-10, 10, (200, 4))
    ]
    fits = []
    for _ in range(300):  # the RAIM's weighted least-squares fits, every row left out in turn
        n = int(rng.integers(4, 16))
        H, res, w = rng.normal(size=(n, 3)), rng.normal(size=n), rng.uniform(0.1, 10.0, n)
        fits.append(_fde_statistics(res, H.reshape(-1), w, 3))
    out["_fde_statistics"] = [np.concatenate(fits).tobytes()]
    triples = []  # the cross-check's choice of triple (its CRLB per triple through position_crlb_one)
    for _ in range(2_000):
        n = int(rng.integers(3, 9))
        rx3, ry3, var3 = rng.uniform(-10, 10, n), rng.uniform(-10, 10, n), rng.uniform(1e-7, 1e-4, n)
        triples.append(best_triple(0.3, -0.2, rx3, ry3, var3, 1e-6, float(rng.uniform(1e-5, 1e-2))))
    out["best_triple"] = [np.array(triples).tobytes()]
    rows = rng.normal(size=(3_000, 20))  # an integrity window: stamps, map rows of 40, flags 0/1, sums
    rows[:, 0] = np.sort(rng.uniform(0.0, 2.0, 3_000))
    rows[:, 2] = rng.integers(0, 40, 3_000)
    rows[:, [7, 8, 14]] = rng.integers(0, 2, (3_000, 3))
    excluded = (rng.uniform(size=40) < 0.1).astype(np.int64)
    tally = _window_tally(rows.reshape(-1), 0, 3_000, 2.1, 1.0, 0.125, excluded)
    out["_window_tally"] = [np.asarray(a).tobytes() for a in tally]
    std = np.where(rng.uniform(size=200) < 0.05, 0.0, rng.uniform(1e-3, 1e-2, 200))
    info = [_information_sums(float(hx[i]), float(hy[i]), rx[:200], ry[:200], std) for i in range(50)]
    out["_information_sums"] = [np.array([[ok, *a, *b, sv] for ok, a, b, sv in info], dtype=np.float64).tobytes()]
    out.update(_estimator_kernel_outputs(rng))
    return out


def _estimator_kernel_outputs(rng: np.random.Generator) -> dict[str, list[bytes]]:
    """The streaming EKF's compiled path (``positioning._fast``): prediction, gate, gate and update."""
    from agvnav.positioning import _fast

    out: dict[str, list[bytes]] = {"move_state": [], "gate_rows": [], "gate_accept": []}
    n = 60
    xy, radius = rng.uniform(0.0, 20.0, (n, 2)), rng.uniform(0.02, 0.05, n)
    rows = _fast.reflector_rows(xy, radius)
    tab = _fast.gate_table(rows, rng.uniform(1e-6, 4e-6, n))
    spec = GateSpec(1e-7, 25.0, 10.8, 0.002, 0.1, True)
    index = BearingIndex(xy, radius, (0.3, 0.05, 0.01), spec)
    gc = _fast.gate_constants(spec, (0.3, 0.05, 0.01), index.grid_constants(), 1e-7, 0.05, 20.0, True)
    gc_plain = _fast.gate_constants(GateSpec(1e-7, 25.0, 10.8, 0.002, 0.1), (0.3, 0.05, 0.01), None, 1e-7)
    sight, claimed = rng.uniform(size=n) < 0.9, np.where(rng.uniform(size=n) < 0.1, 1.0, -math.inf)
    for k in range(2_000):
        pose = (*rng.uniform(2.0, 18.0, 2).tolist(), float(rng.uniform(-4.0, 4.0)))
        a = rng.normal(0.0, 0.01, (3, 3))
        P = tuple((a @ a.T + 1e-6 * np.eye(3)).reshape(9).tolist())
        M = tuple((np.eye(3) + rng.normal(0.0, 0.3, (3, 3))).reshape(9).tolist())
        X = tuple(rng.normal(0.0, 1e-4, 6).tolist())
        steered = (bool(k % 2), 1.2, 1e-3, 4e-5, 0.5) if k % 3 else None
        mc = _fast.move_constants((1e-4, 2e-4, 1e-5, 3e-4), steered, True, True, (9e-6, 1.2e-5))
        dd, dth, dl = rng.uniform(-0.05, 0.05, 3).tolist()
        moved = _fast.move_state((0.1, 0.2, 0.3), pose, P, M, X, dd, dth, dl if k % 5 == 0 else 0.0, abs(dd), mc)
        out["move_state"].append(np.array([v for part in moved for v in part]).tobytes())
        z = float(rng.uniform(-math.pi, math.pi))
        C = rng.normal(0.0, 1e-3, (n, 6))
        for consts in (gc, gc_plain):
            got = _fast.gate_rows(z, 1.05, pose, P, M, C, claimed, sight, tab, consts, *index.grid_cells())
            out["gate_rows"].append(np.array(got, dtype=np.float64).tobytes())
        res = _fast.gate_accept(z, 1.05, pose, P, M, X, C, claimed, sight, tab, gc, *index.grid_cells())
        flat = [float(v) for part in res[:-1] for v in part] + [float(res[-1])]
        out["gate_accept"] += [np.array(flat).tobytes(), C.tobytes()]
    return out


_FAST = "positioning/test_integrity_fast.py::"
_FLAGS = "positioning/test_triangulation_flags.py::"
#: The integrity check's kernels (positioning._integrity_fast) and the test that runs each, compiled and
#: interpreted, against the bits of a reference or of the other mode.
_INTEGRITY_KERNEL_TESTS = {
    "py_hypot": _FAST + "test_py_hypot_is_cpythons_hypot_bit_for_bit",
    "_dl_mul": _FAST + "test_py_hypot_is_cpythons_hypot_bit_for_bit",
    "total_fix": _FAST + "test_total_fix_covariance_and_flag_are_triangulates",
    "fix_covariance": _FAST + "test_total_fix_covariance_and_flag_are_triangulates",
    "nonlinear_fix": _FAST + "test_total_fix_covariance_and_flag_are_triangulates",
    "crosscheck_fix": _FAST + "test_crosscheck_fix_modes_agree_bit_for_bit",
    "_head": _FAST + "test_crosscheck_fix_modes_agree_bit_for_bit",
    "_edge_bearing": _FAST + "test_crosscheck_fix_modes_agree_bit_for_bit",
    "_round_half_even": _FAST + "test_crosscheck_fix_modes_agree_bit_for_bit",  # windows of > 8 reflectors
    "mean_innovations": _FAST + "test_revolution_and_mean_innovations_are_the_former_numpy_sums",
    "revolution_innovations": _FAST + "test_revolution_and_mean_innovations_are_the_former_numpy_sums",
    "information": _FAST + "test_information_is_the_former_pdop_and_survey_floor",
    "_inverse3": _FAST + "test_information_is_the_former_pdop_and_survey_floor",
    "in_range": _FAST + "test_in_range_is_hypot_against_the_range_at_the_boundary_too",
    "revolution_offset": _FAST + "test_revolution_offset_and_window_fde_modes_agree_bit_for_bit",
    "window_fde": _FAST + "test_revolution_offset_and_window_fde_modes_agree_bit_for_bit",
    "_floats": _FAST + "test_revolution_offset_and_window_fde_modes_agree_bit_for_bit",
    "nis_per_reflector": _FAST + "test_nis_per_reflector_is_the_former_sum_in_order_of_first_sighting",
    # batch triangulation (issue 29)
    "total_batch": _FLAGS + "test_total_batch_modes_agree_bit_for_bit_and_equal_the_float_kernel",
    "_div": _FLAGS + "test_div_is_numpys_division",
    "_wrap": _FLAGS + "test_the_fast_wrap_is_wrap_angle_scalar_bit_for_bit",
    "_layout_ok_kernel": _FLAGS + "test_layout_flags_are_the_former_flags_in_both_modes",
}


def test_every_kernel_agrees_bit_for_bit_on_random_inputs() -> None:
    """1e5 random beam offsets and more per kernel: the two modes give the same bits.

    ``offset_one`` once used ``math.hypot``: CPython's and libm's differ in the last bit on
    ~0.6 % of pairs, so ~600 of these distances differed between the modes.
    """
    _jit.set_compiled(False)
    interpreted = _random_outputs()
    _jit.set_compiled(True)
    compiled = _random_outputs()
    for name, got in compiled.items():
        assert got == interpreted[name], name
    tested = {"wrap_angle_scalar", "offset_one", "offsets_at", "grid_crossings", "wrapped_offsets", "line_of_sight",
              "_hits_wall", "_hits_disc", "near_rows", "near_one", "grid_rows", "_visit_box", "chord_brackets",
              "chord_step", "seen_in_order", "scan_hermite", "_finite_poses", "hermite_poses", "_fde_statistics",
              "_solve_augmented", "_normal_equations", "best_triple", "position_crlb_one", "_window_tally",
              "_information_sums", "move_state", "_sinc_k", "_dsinc_k", "gate_rows", "gate_accept", "schmidt_accept"}
    # the integrity check's kernels: bit for bit in both modes elsewhere, each by the test named here
    # (nested kernels by the test of the kernel that calls them)
    elsewhere = _INTEGRITY_KERNEL_TESTS
    root = Path(__file__).parent
    for name, where in elsewhere.items():
        path, test = where.split("::")
        assert f"def {test}(" in (root / path).read_text(encoding="utf-8"), f"{name}: no {where}"
    tested |= set(elsewhere)
    known = {k.py_func.__name__ for k in _jit.kernels()}
    assert known <= tested, f"kernels without a bit-for-bit test here: {sorted(known - tested)}"


def test_offset_distance_is_the_correctly_rounded_root() -> None:
    """The head-to-centre distance is sqrt(dx^2 + dy^2) rounded once, in either mode (not hypot's own rounding)."""
    dx, dy = 0.28183784439970383, 0.7558042041572239  # math.hypot gives 1 ulp more
    for on in (False, True):
        _jit.set_compiled(on)
        d = beam.offset_one(0.0, 0.0, 0.0, 0.0, dx, dy, 0.04, 0.0, 0.0, 0.0, 1.0, 1)[3]
        assert d == math.sqrt(dx * dx + dy * dy)


def test_mode_switches_and_environment_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    _jit.set_compiled(False)
    assert not _jit.compiled()
    k = beam.offset_one
    k(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.04, 0.0, 0.0, 0.0, 1.0, 1)
    assert k._impl is k.py_func  # type: ignore[attr-defined]
    monkeypatch.setenv("AGVNAV_JIT", "1")
    _jit.set_compiled(False)
    assert _jit.compiled()
    monkeypatch.setenv("AGVNAV_JIT", "0")
    assert _jit.compiled()  # the environment is read when the mode is resolved, not on every call
    monkeypatch.setenv("AGVNAV_JIT", "maybe")
    with pytest.raises(ValueError, match="AGVNAV_JIT"):
        _jit.set_compiled(True)
    monkeypatch.delenv("AGVNAV_JIT")


def test_set_compiled_for_run_picks_by_work() -> None:
    assert not _jit.set_compiled_for_run(26.0, 9)  # the default scenario: numba's start-up costs more
    assert _jit.set_compiled_for_run(406.0, 102)  # warehouse_mission: compiled pays
    assert _jit.compiled()
    with pytest.raises(ValueError, match="sim_seconds"):
        _jit.set_compiled_for_run(-1.0, 3)


def test_set_compiled_for_run_reports_the_mode_in_force(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AGVNAV_JIT", "1")
    assert _jit.set_compiled_for_run(26.0, 9)  # the estimate says interpreted; the environment wins
    monkeypatch.setenv("AGVNAV_JIT", "0")
    assert not _jit.set_compiled_for_run(406.0, 102)


def test_the_wrap_kernel_is_wrap_angle_bit_for_bit_in_both_modes() -> None:
    """One scalar wrap (geometry.angles), compiled or not: wrap_angle's bits, NaN for NaN and +-inf."""
    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(-40.0, 40.0, 2_000), rng.normal(0.0, 1e-3, 200),
                        [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.0, 5e-324, 1e300, -1e300]])
    want = wrap_angle(a)
    for on in (False, True):
        _jit.set_compiled(on)
        got = np.array([wrap_angle_kernel(float(v)) for v in a])
        assert got.tobytes() == want.tobytes()
        assert all(math.isnan(wrap_angle_kernel(v)) for v in (math.nan, math.inf, -math.inf))
    assert np.array([wrap_angle_scalar(float(v)) for v in a]).tobytes() == want.tobytes()


def test_the_public_module_is_the_cli_s_way_in() -> None:
    """agvnav.jit exposes the mode functions; the CLI uses it, not the private agvnav._jit."""
    import agvnav.jit as public

    assert public.set_compiled_for_run is _jit.set_compiled_for_run and public.compiled is _jit.compiled
    cli = Path(public.__file__).parent / "cli"
    users = [p.name for p in cli.rglob("*.py") if "agvnav._jit" in p.read_text(encoding="utf-8")]
    assert users == []


def test_kernel_bound_follows_the_mode() -> None:
    """``Kernel.bound`` is what a call runs: the plain function interpreted, the dispatcher compiled."""
    k = _fast.MOVE_STATE
    _jit.set_compiled(False)
    assert k.bound() is k.py_func
    _jit.set_compiled(True)
    assert k.bound() is k.dispatcher()
    args = ((0.0, 0.0, 0.0), (1.0, 2.0, 0.3), (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5),
            (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0,) * 6, 0.01, 0.002, 0.0, 0.01,
            _fast.move_constants((1e-3, 3e-3, 1e-3, 1e-3), None, True, False, (0.0, 0.0)))
    assert k.bound()(*args) == k.py_func(*args) == k(*args)
