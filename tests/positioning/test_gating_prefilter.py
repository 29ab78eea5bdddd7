"""``gating.near_one``'s cross-product pre-test rejects only reflectors its exact angle test rejects (issue 11)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav import _jit
from agvnav.geometry import wrap_angle
from agvnav.positioning.gating import near_rows


def _exact_rows(rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range):  # type: ignore[no-untyped-def]
    """The test of ``near_one`` without the pre-test, over arrays (NumPy's arctangent)."""
    dx, dy = rx - hx, ry - hy
    d2 = dx * dx + dy * dy
    d = np.sqrt(d2)
    e = d2 - r2
    with np.errstate(divide="ignore", invalid="ignore"):
        window = np.sqrt(a4 + b4 / np.maximum(e, 1e-300)) + half_pi_r / np.maximum(d, 1e-300)
    w = wrap_angle(beam - np.arctan2(dy, dx))
    keep = (d <= max_range) & ((e <= 0.0) | (np.abs(w) < window))
    return np.flatnonzero(keep).tolist()


@pytest.mark.parametrize("compiled", [False, True])
def test_prefilter_keeps_the_exact_rows(compiled: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("AGVNAV_JIT", raising=False)
    before = _jit.compiled()
    _jit.set_compiled(compiled)
    try:
        rng = np.random.default_rng(17)
        n_rows = 0
        for _ in range(150 if compiled else 30):
            n = 300
            rx, ry = rng.uniform(-30.0, 30.0, n), rng.uniform(-30.0, 30.0, n)
            r = rng.uniform(0.01, 0.5, n)
            r2, half_pi_r = r * r, 0.5 * math.pi * r
            hx, hy = rng.uniform(-10.0, 10.0, 2)
            hx, hy = float(hx), float(hy)
            if rng.uniform() < 0.1:  # the head inside a reflector: always kept
                hx, hy = float(rx[0]), float(ry[0])
            beam = float(rng.uniform(-10.0, 10.0))
            a4, b4 = float(10 ** rng.uniform(-8.0, 0.0)), float(10 ** rng.uniform(-8.0, -1.0))
            got = near_rows(rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, 40.0).tolist()
            assert got == _exact_rows(rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, 40.0)
            n_rows += len(got)
        assert n_rows > 100  # not vacuous: reflectors pass as well as fail
    finally:
        _jit.set_compiled(before)
