"""Shared test configuration: hypothesis profiles (CI keeps example counts small), the kernel-mode fixture."""

import os
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, settings

from agvnav import _jit

settings.register_profile(
    "ci", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)
settings.register_profile("dev", max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def restore_jit_mode(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Run a test that switches the kernels' mode (``set_compiled``) and give the mode back after it."""
    monkeypatch.delenv("AGVNAV_JIT", raising=False)
    before = _jit.compiled()
    yield
    _jit.set_compiled(before)
