"""Campaign files: strict schema, errors naming file, line and key; override values checked against the scenario."""

import pytest

from agvnav.campaign import load_campaign, parse_campaign
from agvnav.campaign.spec import builtin_campaign_names
from agvnav.world.scenario import ScenarioError, builtin_scenario


def _error(write_campaign, body, short=True):
    path = write_campaign(body, short)
    with pytest.raises(ScenarioError) as info:
        load_campaign(path)
    return path, info.value


def _line_of(path, needle):
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def test_valid_campaign_loads(write_campaign):
    spec = load_campaign(write_campaign("seed: 3\nseeds: 2\ngrid:\n  traction.speed_m_s: [0.2, 0.3]\n"))
    assert spec.seed == 3 and spec.replicates == 2 and spec.swept == ["traction.speed_m_s"]
    assert spec.overrides["start.lateral_offset_m"] == 0.02


def test_unknown_key_names_line(write_campaign):
    path, err = _error(write_campaign, "runs: 2\nmetrix: [x]\n")
    assert err.key == ("metrix",) and err.line == _line_of(path, "metrix")
    assert str(err).startswith(f"{path}:{err.line}: metrix: unknown key")


def test_bad_grid_value_is_reported_at_its_own_line(write_campaign):
    body = "seeds: 1\ngrid:\n  goniometer.p_miss:\n    - 0.1\n    - 1.5\n"
    path, err = _error(write_campaign, body)
    assert err.key == ("grid", "goniometer.p_miss", 1)
    assert err.line == _line_of(path, "- 1.5")
    assert "less than or equal to 1" in str(err)


def test_bad_fixed_override_names_its_key(write_campaign):
    path, err = _error(write_campaign, "runs: 2\noverrides:\n  traction.speed_m_s: -1.0\n", short=False)
    assert err.key == ("overrides", "traction.speed_m_s") and err.line == _line_of(path, "speed_m_s")


def test_override_through_a_value_is_refused(write_campaign):
    _, err = _error(write_campaign, "runs: 2\ngrid:\n  traction.speed_m_s.x: [1]\n".replace("runs: 2\n", ""))
    assert err.key == ("grid", "traction.speed_m_s.x", 0) and "not a mapping" in str(err)


def test_random_needs_exactly_one_distribution(write_campaign):
    path, err = _error(write_campaign, "runs: 2\nrandom:\n  goniometer.p_miss: {uniform: [0, 0.1], normal: [0, 1]}\n")
    assert err.key[:2] == ("random", "goniometer.p_miss") and err.line == _line_of(path, "p_miss")
    assert "exactly one of" in str(err)


def test_random_range_checked_against_scenario(write_campaign):
    path, err = _error(write_campaign, "runs: 2\nrandom:\n  goniometer.p_miss:\n    uniform: [0.0, 2.0]\n")
    assert err.key == ("random", "goniometer.p_miss", "uniform") and err.line == _line_of(path, "uniform")


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("grid:\n  traction.speed_m_s: [0.2]\nruns: 3\n", "not runs"),
        ("seed: 1\n", "give runs"),
        ("runs: 2\nseeds: 2\n", "give runs"),
        ("runs: 0\n", "greater than or equal to 1"),
        ("runs: 2\ngrid: {}\nrandom:\n  a.b: {choice: [1]}\n", "a.b"),
    ],
)
def test_run_count_rules(write_campaign, body, needle):
    _, err = _error(write_campaign, body)
    assert needle in str(err)


def test_unknown_metric_listed(write_campaign):
    path, err = _error(write_campaign, "runs: 2\nmetrics: [positioning_rms_m, speed]\n")
    assert err.key == ("metrics", 1) and err.line == _line_of(path, "metrics")
    assert "unknown metric 'speed'" in str(err) and "positioning_rms_m" in str(err) and "integrity.<name>" in str(err)
    body = "runs: 2\nmetrics: [integrity.nees_mean, extra.max_abs_hitch_angle_rad]\n"
    ok = load_campaign(write_campaign(body, name="ok.yaml"))
    assert ok.metrics == ["integrity.nees_mean", "extra.max_abs_hitch_angle_rad"]


def test_missing_base_and_bad_yaml(tmp_path):
    with pytest.raises(ScenarioError, match=r"c\.yaml:1: base: .*no such scenario"):
        parse_campaign("base: nowhere.yaml\nruns: 1\n", source="c.yaml")
    with pytest.raises(ScenarioError, match=r"c\.yaml:3: invalid YAML: duplicate key 'runs'"):
        parse_campaign("base: guidance_test\nruns: 1\nruns: 2\n", source="c.yaml")
    with pytest.raises(ScenarioError, match="no such campaign file"):
        load_campaign(tmp_path / "missing.yaml")


def test_base_path_relative_to_the_campaign_file(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "my.yaml").write_text(builtin_scenario("guidance_test").read_text())
    (tmp_path / "sub" / "c.yaml").write_text("base: my.yaml\nruns: 1\n")
    spec = load_campaign(tmp_path / "sub" / "c.yaml")
    assert spec.resolve_base() == str(tmp_path / "sub" / "my.yaml")


def test_shipped_campaign_loads_by_name():
    assert "default_seeds" in builtin_campaign_names()
    spec = load_campaign("default_seeds")
    assert spec.base == "guidance_test" and set(spec.swept) == {"traction.speed_m_s", "goniometer.p_miss"}
