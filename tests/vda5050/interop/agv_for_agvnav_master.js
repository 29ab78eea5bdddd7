// An independent vehicle (coatyio's vda-5050-lib: AgvController with its VirtualAgvAdapter, VDA 5050 2.0)
// for `agvnav fleet` to drive: it starts at a node of the network and runs until SIGTERM/SIGINT.
//
// usage: node agv_for_agvnav_master.js BROKER_URL MANUFACTURER SERIAL NETWORK_JSON START_NODE
// Prints {"event": "started"} once connected, then one JSON line per order it receives.
"use strict";

const fs = require("fs");
const { AgvController, VirtualAgvAdapter } = require("vda-5050-lib");

const [brokerUrl, manufacturer, serialNumber, networkPath, startNode] = process.argv.slice(2);
const net = JSON.parse(fs.readFileSync(networkPath, "utf8"));
const start = net.nodes[startNode];

async function main() {
    const agv = new AgvController(
        { manufacturer, serialNumber },
        { interfaceName: "uagv", transport: { brokerUrl }, vdaVersion: "2.0.0" },
        { agvAdapterType: VirtualAgvAdapter, publishVisualizationInterval: 0 },
        { initialPosition: { mapId: net.mapId, x: start.x, y: start.y, theta: start.theta, lastNodeId: startNode },
          vehicleSpeed: 10 },
    );
    await agv.start();
    await agv.subscribe("order", (order) => console.log(JSON.stringify({ event: "order", orderId: order.orderId,
        orderUpdateId: order.orderUpdateId, nodes: order.nodes.map((n) => n.nodeId) })));
    console.log(JSON.stringify({ event: "started" }));
    const stop = async () => { await agv.stop(); process.exit(0); };
    process.on("SIGTERM", stop);
    process.on("SIGINT", stop);
}

main().catch((e) => { console.log(JSON.stringify({ event: "fatal", error: String(e) })); process.exit(1); });
