"""agvnav._jit: lazy kernels that run compiled (numba) or interpreted with the same numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav import _jit
from agvnav.geometry import wrap_angle
from agvnav.positioning.gating import near_rows
from agvnav.sensors import beam
from agvnav.vehicles.tricycle import hermite_poses


@pytest.fixture(autouse=True)
def _restore_mode(monkeypatch: pytest.MonkeyPatch) -> object:
    monkeypatch.delenv("AGVNAV_JIT", raising=False)
    before = _jit.compiled()
    yield
    _jit.set_compiled(before)


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


def test_mode_switches_and_environment_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    _jit.set_compiled(False)
    assert not _jit.compiled()
    k = beam.offset_one
    k(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.04, 0.0, 0.0, 0.0, 1.0, 1)
    assert k._impl is k.py_func  # type: ignore[attr-defined]
    monkeypatch.setenv("AGVNAV_JIT", "1")
    _jit.set_compiled(False)
    assert _jit.compiled()
    monkeypatch.setenv("AGVNAV_JIT", "maybe")
    with pytest.raises(ValueError, match="AGVNAV_JIT"):
        _jit.compiled()


def test_set_compiled_for_run_picks_by_work() -> None:
    assert not _jit.set_compiled_for_run(26.0, 9)  # the default scenario: numba's start-up costs more
    assert _jit.set_compiled_for_run(406.0, 102)  # warehouse_mission: compiled pays
    assert _jit.compiled()
    with pytest.raises(ValueError, match="sim_seconds"):
        _jit.set_compiled_for_run(-1.0, 3)
