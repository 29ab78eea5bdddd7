"""LIF 1.0 export (validates against the vendored schema) and lenient import (fixes reported, problems located)."""

from __future__ import annotations

import copy
import json
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from jsonschema import Draft7Validator
from typer.testing import CliRunner

from agvnav.cli.app import app
from agvnav.routes.network import RouteNetwork, load_network
from agvnav.traffic.lif import LifError, export_lif, import_lif, lif_problem, lif_schema, parse_lif_text

SHIPPED = ("hall_loop", "hall_loop_arcs", "warehouse", "warehouse_arcs")
runner = CliRunner()


def _points(net: RouteNetwork, edge: str, n: int = 300) -> np.ndarray:
    """``n`` points equally spaced in arclength along the edge's sampled curve."""
    p = net.edges[edge].curve.points
    d = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    s = np.linspace(0.0, d[-1], n)
    return np.column_stack([np.interp(s, d, p[:, 0]), np.interp(s, d, p[:, 1])])


@pytest.mark.parametrize("name", SHIPPED)
def test_export_validates_and_round_trips(name: str) -> None:
    net = load_network(name)
    doc = export_lif(net, datetime(2026, 1, 2, 3, 4, 5, tzinfo=UTC))
    assert not list(Draft7Validator(lif_schema()).iter_errors(doc))
    assert doc["metaInformation"]["exportTimestamp"] == "2026-01-02T03:04:05.00Z"
    exact = import_lif(doc)
    assert exact.fixes == []
    assert exact.data["edges"] == [e.model_dump(mode="json", by_alias=True) for e in net.spec.edges]
    plain = import_lif(doc, use_extensions=False).network  # only the LIF fields: NURBS trajectories
    assert set(plain.edges) == set(net.edges) and plain.stations == net.stations
    for eid, e in net.edges.items():
        p = plain.edges[eid]
        assert (p.source, p.target, p.speed, p.modes, p.models) == (e.source, e.target, e.speed, e.modes, e.models)
        assert p.curve.length == pytest.approx(e.curve.length, abs=1e-3)
        # 0.6 mm: the 0.1 m chords of the sampled arcs (the clothoid fit itself is within 0.5 mm)
        assert float(np.max(np.hypot(*(_points(net, eid) - _points(plain, eid)).T))) < 1e-3
    for nid, n in net.nodes.items():
        m = plain.nodes[nid]
        assert (m.x, m.y) == (n.x, n.y) and (n.heading is None or math.isclose(
            math.cos(m.heading - n.heading), 1.0))  # type: ignore[operator]


def _tiny() -> dict[str, Any]:
    """A small hand-written LIF layout: a one-way line, an edge back along a NURBS, one station."""
    prop = {"vehicleTypeId": "tricycle", "rotationAllowed": False, "vehicleOrientation": 0.0}
    return {
        "metaInformation": {"projectIdentification": "tiny", "creator": "test", "exportTimestamp": "x",
                            "lifVersion": "1.0.0"},
        "layouts": [{
            "layoutId": "L1", "layoutVersion": "1",
            "nodes": [{"nodeId": "A", "nodePosition": {"x": 0.0, "y": 0.0},
                       "vehicleTypeNodeProperties": [{"vehicleTypeId": "tricycle", "theta": 0.0}]},
                      {"nodeId": "B", "nodePosition": {"x": "4.0", "y": 0.0},
                       "vehicleTypeNodeProperties": [{"vehicleTypeId": "tricycle"}]}],
            "edges": [{"edgeId": "AB", "startNodeId": "A", "endNodeId": "B",
                       "vehicleTypeEdgeProperties": [prop | {"maxSpeed": "0.8"}]},
                      {"edgeId": "BA", "startNodeId": "B", "endNodeId": "A", "vehicleTypeEdgeProperties": [
                          prop | {"trajectory": {"degree": 2, "knotVector": [0, 0, 0, 1, 1, 1], "controlPoints": [
                              {"x": 4.0, "y": 0.0}, {"x": 2.0, "y": 2.0, "weight": 0.5}, {"x": 0.0, "y": 0.0}]}}]}],
        }],
    }


def test_import_fixes_what_has_one_meaning_and_says_so() -> None:
    doc = _tiny()
    result = import_lif(doc)
    assert doc == _tiny()  # the caller's document is not changed
    fixes = "\n".join(result.fixes)
    assert "$.layouts[0].stations: missing, taken as []" in fixes
    assert "$.layouts[0].nodes[1].nodePosition.x: number written as a string '4.0'" in fixes
    assert "$.layouts[0].edges[1].vehicleTypeEdgeProperties[0].trajectory.controlPoints: weights below 1" in fixes
    net = result.network
    assert net.edges["AB"].speed == 0.8 and net.edges["AB"].models == frozenset({"tricycle"})
    assert net.edges["BA"].curve.kind == "nurbs" and net.nodes["A"].heading == 0.0
    assert lif_problem(doc) is not None  # as given it does not validate


def test_a_trajectory_off_its_nodes_becomes_a_line_and_is_reported() -> None:
    doc = _tiny()
    doc["layouts"][0]["stations"] = []
    doc["layouts"][0]["edges"][1]["vehicleTypeEdgeProperties"][0]["trajectory"]["controlPoints"][0]["x"] = 9.0
    result = import_lif(doc)
    assert result.network.edges["BA"].curve.kind == "line"
    assert any("edges[1]: trajectory runs from (9, 0)" in f and "straight line" in f for f in result.fixes)


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d["layouts"][0]["nodes"][0]["nodePosition"].pop("x"),
     "$.layouts[0].nodes[0].nodePosition: 'x' is a required property"),
    (lambda d: d.pop("metaInformation"), "$: 'metaInformation' is a required property"),
    (lambda d: d["layouts"][0]["edges"][0].update(endNodeId="Z"), "$.layouts[0].edges[0].endNodeId: unknown node 'Z'"),
    (lambda d: d["layouts"][0]["nodes"][1]["nodePosition"].update(x="four"),
     "$.layouts[0].nodes[1].nodePosition.x: 'four' is not of type 'number'"),
])
def test_a_file_that_is_not_lif_names_the_first_problem(change: Any, message: str) -> None:
    doc = copy.deepcopy(_tiny())
    change(doc)
    with pytest.raises(LifError) as err:
        import_lif(doc)
    assert message in str(err.value)


def test_not_json_names_line_and_column() -> None:
    with pytest.raises(LifError, match=r"f.json:2:5: not JSON"):
        parse_lif_text('{"a":\n    }', "f.json")
    with pytest.raises(LifError, match=r"\$: \[\] is not of type 'object'"):
        import_lif([])


def test_cli_export_import_and_refusals(tmp_path: Path) -> None:
    lif, net = tmp_path / "w.json", tmp_path / "w.yaml"
    res = runner.invoke(app, ["routes", "export-lif", "hall_loop", "--out", str(lif)])
    assert res.exit_code == 0 and "valid LIF 1.0.0" in res.output, res.output
    assert json.loads(lif.read_text())["layouts"][0]["layoutId"] == "hall_loop"
    res = runner.invoke(app, ["routes", "import-lif", str(lif), "--out", str(net)])
    assert res.exit_code == 0 and "0 fix(es)" in res.output, res.output
    assert load_network(net).spec.edges == load_network("hall_loop").spec.edges
    again = runner.invoke(app, ["routes", "export-lif", "hall_loop", "--out", str(lif)])
    assert again.exit_code == 2 and "use --force" in again.output
    assert runner.invoke(app, ["routes", "export-lif", "hall_loop", "--out", str(lif), "--force"]).exit_code == 0
    tiny = tmp_path / "tiny.json"
    tiny.write_text(json.dumps(_tiny()))
    res = runner.invoke(app, ["routes", "import-lif", str(tiny), "--out", str(tmp_path / "t.yaml")])
    assert res.exit_code == 0 and res.output.count("fixed: ") == 4, res.output
    bad = _tiny()
    del bad["layouts"][0]["nodes"][0]["nodeId"]
    tiny.write_text(json.dumps(bad))
    res = runner.invoke(app, ["routes", "import-lif", str(tiny), "--out", str(tmp_path / "u.yaml")])
    assert res.exit_code == 2 and "$.layouts[0].nodes[0]: 'nodeId' is a required property" in res.output
    assert len(res.output.strip().splitlines()) == 1 and not (tmp_path / "u.yaml").exists()
