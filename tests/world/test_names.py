"""Name resolution (issue 29): what `hall_loop`, `warehouse`, `lab` or `guidance_test` mean where written.

A name written inside a shipped file is the shipped data, whatever lies in the current
folder; a name written inside a user's file is a shipped name first, else a path relative
to that file's folder (never the current folder); a name typed on the command line may
be a local file; a folder never hides a shipped name.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from agvnav.campaign.spec import load_campaign
from agvnav.routes.network import load_network
from agvnav.sim.mission import load_mission_network, plan_mission
from agvnav.world.map import load_map
from agvnav.world.scenario import ScenarioError, builtin_scenario, load_scenario, parse_scenario

SHIPPED_ROUTES = Path(str(builtin_scenario("mission_hall").parent.parent / "routes"))


def _impostor() -> str:
    """The shipped hall_loop network renamed and with every speed limit at 0.1 m/s: valid, but not the same."""
    text = (SHIPPED_ROUTES / "hall_loop.yaml").read_text(encoding="utf-8").replace("name: hall_loop", "name: local")
    return re.sub(r"speed_m_s: [0-9.]+", "speed_m_s: 0.1", text)


def _plan_figures(name: str) -> tuple[float, list[float], tuple[str, ...]]:
    plan = plan_mission(load_scenario(name))
    return plan.path.length, [leg.route.time_s for leg in plan.legs if leg.route is not None], plan.seg_edge


def test_shipped_scenarios_ignore_files_and_folders_in_the_current_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file ``hall_loop`` changed mission_hall's results; a folder ``warehouse`` broke warehouse_mission."""
    monkeypatch.chdir(tmp_path)
    clean_hall, clean_warehouse = _plan_figures("mission_hall"), _plan_figures("warehouse_mission")
    (tmp_path / "hall_loop").write_text(_impostor(), encoding="utf-8")
    (tmp_path / "warehouse").mkdir()
    (tmp_path / "hall").mkdir()  # the map's name, as a folder
    assert load_mission_network(load_scenario("mission_hall")).name == "hall_loop"
    assert _plan_figures("mission_hall") == clean_hall
    assert _plan_figures("warehouse_mission") == clean_warehouse


def test_a_users_scenario_names_shipped_data_or_files_beside_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """In a user's file: a shipped name is the shipped data, ``./name`` and other paths are beside the file."""
    mine, elsewhere = tmp_path / "mine", tmp_path / "elsewhere"
    mine.mkdir()
    elsewhere.mkdir()
    (mine / "hall_loop").write_text(_impostor(), encoding="utf-8")
    (elsewhere / "net.yaml").write_text(_impostor(), encoding="utf-8")
    text = builtin_scenario("mission_hall").read_text(encoding="utf-8")
    monkeypatch.chdir(elsewhere)

    def network(name: str) -> str:
        sc = parse_scenario(text.replace("network: hall_loop", f"network: {name}"), str(mine / "s.yaml"), mine)
        return load_mission_network(sc).name

    assert network("hall_loop") == "hall_loop"  # the shipped one, though a file of that name lies beside
    assert network("./hall_loop") == "local"  # written as a path: the user's file
    with pytest.raises(ScenarioError, match=r"mission\.network: 'net\.yaml': no such route network file"):
        network("net.yaml")  # relative to the scenario's folder, not to the current folder
    (mine / "sub").mkdir()
    with pytest.raises(ScenarioError, match=r"mission\.network: 'sub': is a directory"):
        network("sub")


def test_command_line_names_local_files_first_and_never_folders(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Typed by the user: a local file wins over the shipped name; a folder of that name does not."""
    monkeypatch.chdir(tmp_path)
    for name in ("warehouse", "lab", "guidance_test"):
        (tmp_path / name).mkdir()
    assert load_network("warehouse").name == "warehouse"
    assert load_map("lab").reflectors == load_map(SHIPPED_ROUTES.parent / "maps" / "lab.yaml").reflectors
    assert load_scenario("guidance_test").name == "guidance_test"
    (tmp_path / "hall_loop").write_text(_impostor(), encoding="utf-8")
    assert load_network("hall_loop").name == "local"


def test_a_campaigns_base_is_the_shipped_scenario(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``base: guidance_test`` in the shipped campaign took a file ``guidance_test`` of the current folder."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "guidance_test").write_text("name: local\nvehicle: {model: tricycle}\nseed: -1\n", encoding="utf-8")
    spec = load_campaign("default_seeds")
    assert Path(spec.resolve_base()) == builtin_scenario("guidance_test")
    assert spec.base == "guidance_test"
