"""A master control's messages for agvnav's tests and bench: orders over a route network, instant actions.

Not a master control (job dispatch and traffic control are left to a later issue): it writes the
messages such a master sends, in the form of the version spoken (2.x edges name their nodes, 3.0
edges do not), with its own header ids per topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime

from agvnav.routes.network import RouteNetwork
from agvnav.vda5050.messages import iso_timestamp
from agvnav.vda5050.schemas import JsonObject, major

__all__ = ["MasterMessages"]


@dataclass
class MasterMessages:
    """Messages to vehicle ``serial`` of ``manufacturer`` in ``version`` over ``network`` on map ``map_id``."""

    network: RouteNetwork
    map_id: str
    version: str
    manufacturer: str
    serial: str
    headers: dict[str, int] = field(default_factory=dict)

    def _header(self, topic: str) -> JsonObject:
        self.headers[topic] = self.headers.get(topic, -1) + 1
        return {"headerId": self.headers[topic], "timestamp": iso_timestamp(datetime.now(UTC)),
                "version": self.version, "manufacturer": self.manufacturer, "serialNumber": self.serial}

    @staticmethod
    def action(action_type: str, action_id: str, blocking: str = "HARD", **params: object) -> JsonObject:
        """An action with ``params`` as its actionParameters."""
        return {"actionType": action_type, "actionId": action_id, "blockingType": blocking,
                "actionParameters": [{"key": k, "value": v} for k, v in params.items()]}

    def order(self, order_id: str, update_id: int, nodes: Sequence[str], released: int, first_seq: int = 0,
              actions: dict[int, list[JsonObject]] | None = None) -> JsonObject:
        """An order through ``nodes`` (network ids); the first ``released`` nodes (and edges between) are the base.

        ``actions[i]``: the actions of node ``i``. Sequence ids start at ``first_seq`` (an update
        repeats the decision point's).
        """
        acts = actions or {}
        out_nodes: list[JsonObject] = []
        out_edges: list[JsonObject] = []
        for i, nid in enumerate(nodes):
            n = self.network.nodes[nid]
            out_nodes.append({"nodeId": nid, "sequenceId": first_seq + 2 * i, "released": i < released,
                              "nodePosition": {"x": n.x, "y": n.y, "theta": n.heading or 0.0, "mapId": self.map_id},
                              "actions": acts.get(i, [])})
            if i:
                e: JsonObject = {"edgeId": f"{nodes[i - 1]}-{nid}", "sequenceId": first_seq + 2 * i - 1,
                                 "released": i < released, "actions": []}
                if major(self.version) == "v2":
                    e |= {"startNodeId": nodes[i - 1], "endNodeId": nid}
                out_edges.append(e)
        return self._header("order") | {"orderId": order_id, "orderUpdateId": update_id, "nodes": out_nodes,
                                        "edges": out_edges}

    def instant(self, *actions: JsonObject) -> JsonObject:
        """An instantActions message (3.0 instant actions are NONE-blocking)."""
        acts = [a | {"blockingType": "NONE"} for a in actions] if major(self.version) == "v3" else list(actions)
        return self._header("instantActions") | {"actions": acts}
