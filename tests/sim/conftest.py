import pytest

from agvnav.world.scenario import builtin_scenario, parse_scenario


def scenario_text(name: str = "guidance_test", **replace: str) -> str:
    """A shipped scenario's YAML with literal replacements (old=new pairs via dict)."""
    text = builtin_scenario(name).read_text()
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


@pytest.fixture
def short_scenario():
    """The default scenario cut to 4 s of simulated time (for determinism/wiring tests)."""
    text = scenario_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 4.0", 1)
    return parse_scenario(text, "short.yaml")
