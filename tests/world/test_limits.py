"""Size limits (issue 29): a huge document is refused before it is parsed, naming the file, key and line."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from agvnav.cli.app import app
from agvnav.routes.network import load_network
from agvnav.world import strict
from agvnav.world.limits import LIST_LIMITS, MAX_DOCUMENT_BYTES, SCAN_MIN_CHARS
from agvnav.world.map import load_map
from agvnav.world.scenario import ScenarioError, load_scenario
from agvnav.world.yaml_strict import find_long_list

HEAD = "name: huge\nvehicle: {model: tricycle}\nmap: lab\npath:\n  start: [0, 0, 0]\n  segments:\n"


def _huge_scenario(path: Path, n: int) -> Path:
    """A scenario of ``n`` chained short lines and arcs (200,000: the issue's 6.8 MB file)."""
    items = ("    - {type: line, length_m: 0.01}\n", "    - {type: arc, radius_m: 5, sweep_deg: 0.1}\n")
    path.write_text(HEAD + "".join(items[i % 2] for i in range(n)), encoding="utf-8")
    return path


@pytest.fixture
def no_parse(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail if a YAML node tree or data is built (the refusal must come before)."""

    def refuse(*_: Any) -> Any:
        raise AssertionError("the document was parsed before it was refused")

    monkeypatch.setattr(strict, "compose", refuse)
    monkeypatch.setattr(strict, "safe_load_unique", refuse)


def test_a_200000_segment_scenario_is_refused_before_it_is_parsed(tmp_path: Path, no_parse: None) -> None:
    """It took 94 s and 2.9 GB before being refused; the list is now found in the event stream."""
    f = _huge_scenario(tmp_path / "huge.yaml", 200_000)
    assert f.stat().st_size < MAX_DOCUMENT_BYTES  # refused for its list, not for its size
    with pytest.raises(ScenarioError) as info:
        load_scenario(f)
    limit = LIST_LIMITS["scenario"][("path", "segments")]
    assert info.value.key == ("path", "segments")
    assert info.value.line == HEAD.count("\n") + limit + 1  # the first segment past the limit
    assert f"huge.yaml:{info.value.line}: path.segments: more than {limit:,} items" in str(info.value)


def test_the_cli_refuses_a_huge_scenario_with_exit_2(tmp_path: Path, no_parse: None) -> None:
    f = _huge_scenario(tmp_path / "huge.yaml", 200_000)
    res = CliRunner().invoke(app, ["simulate", str(f), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert "path.segments: more than 10,000 items" in res.output and not (tmp_path / "out").exists()


def test_a_file_beyond_the_byte_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    with big.open("wb") as fh:  # sparse: its size is all that is looked at
        fh.truncate(MAX_DOCUMENT_BYTES + 1)
    for load in (load_scenario, load_map, load_network):
        with pytest.raises(ValueError, match=r"big\.yaml: is 8\.0 MiB; a .* file may be at most 8 MiB"):
            load(big)


def test_a_list_at_its_limit_loads_and_one_item_more_is_refused(tmp_path: Path) -> None:
    """Map reflectors and route network nodes: the limit is the largest count accepted."""
    n = LIST_LIMITS["map"][("reflectors",)]
    rows = [f"  - {{id: R{i}, x: {i % 1000}, y: {i // 1000}}}\n" for i in range(n + 1)]
    at_limit, over = tmp_path / "at.yaml", tmp_path / "over.yaml"
    at_limit.write_text("reflectors:\n" + "".join(rows[:n]), encoding="utf-8")
    over.write_text("reflectors:\n" + "".join(rows), encoding="utf-8")
    assert len(load_map(at_limit).reflectors) == n
    with pytest.raises(ValueError, match=rf"over\.yaml:{n + 2}: reflectors: more than {n:,} items"):
        load_map(over)
    m = LIST_LIMITS["route network"][("nodes",)]
    net = tmp_path / "net.yaml"
    net.write_text("network:\n  nodes:\n" + "".join(f"    - {{id: n{i}, x: {i}, y: 0}}\n" for i in range(m + 1))
                   + "  edges: []\n", encoding="utf-8")
    with pytest.raises(ScenarioError, match=rf"net\.yaml:{m + 3}: network\.nodes: more than {m:,} items"):
        load_network(net)


def test_find_long_list_counts_each_list_at_its_own_key() -> None:
    text = ("a:\n  b: [1, 2, 3]\n  c:\n    - {x: [1, 2]}\n    - {x: [1, 2, 3, 4]}\n"
            "  ? [k, l, m, n]\n  : 1\nd: [[1], [1, 2, 3]]\n")
    assert find_long_list(text, {}, 4) is None  # the mapping key [k, l, m, n] is not a counted list
    assert find_long_list(text, {("a", "b"): 2}, 10) == (("a", "b"), 2, 2)
    assert find_long_list(text, {("a", "c", "*", "x"): 3}, 10) == (("a", "c", 1, "x"), 5, 3)
    assert find_long_list(text, {("a", "c", "*", "x"): 4, ("d", "*"): 2}, 10) == (("d", 1), 8, 2)
    assert find_long_list(text, {("a", "b"): 3, ("a", "c", "*", "x"): 4}, 2) == (("d", 1), 8, 2)
    assert find_long_list("a: [1, 2\nb: c\n", {}, 10) is None  # not YAML: the loader reports it, with its line


def test_short_documents_are_not_scanned_and_cannot_reach_a_limit() -> None:
    """The smallest limited item ("- {kind: blind}") is 16 characters: below SCAN_MIN_CHARS, under every limit."""
    smallest = min(n for limits in LIST_LIMITS.values() for n in limits.values())
    assert smallest > SCAN_MIN_CHARS // 16
