"""The kinematics benchmark produces its documented records (figures are not asserted, only their meaning)."""

from __future__ import annotations

from agvnav.bench import kinematics


def test_records_have_the_documented_keys_and_sane_accuracy():
    records = kinematics.run(quick=True, seed=0)
    speed = [r for r in records if "model" in r]
    acc = [r for r in records if "integrator" in r]
    assert len(speed) == len(kinematics.MODELS) and all(r["steps_per_s"] > 0 for r in speed)
    assert {r["integrator"] for r in acc} == {"arc", "midpoint", "euler"}
    circle = {r["integrator"]: r["max_error_m"] for r in acc if r["path"].startswith("circle") and r["step_m"] == 0.05}
    assert circle["arc"] < 1e-9 < circle["midpoint"] < circle["euler"]
