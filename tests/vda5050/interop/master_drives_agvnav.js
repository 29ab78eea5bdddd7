// An independent master control (coatyio's vda-5050-lib, MasterController, VDA 5050 2.0) drives
// `agvnav vehicle --vda 2.0.0` over MQTT through: an order with pick and drop whose horizon an order
// update releases, a pause (startPause/stopPause), a cancelOrder while driving, and an invalid order
// (an unknown node) that must be rejected.
//
// usage: node master_drives_agvnav.js BROKER_URL MANUFACTURER SERIAL NETWORK_JSON
//   NETWORK_JSON: {"mapId": "...", "nodes": {"S1": {"x": .., "y": .., "theta": ..}, ...}}
// Prints one JSON line per step ({"step": ..., "ok": true|false, ...}) and exits 0 when every step passed.
"use strict";

const fs = require("fs");
const { MasterController } = require("vda-5050-lib");

const [brokerUrl, manufacturer, serialNumber, networkPath] = process.argv.slice(2);
const net = JSON.parse(fs.readFileSync(networkPath, "utf8"));
const agv = { manufacturer, serialNumber };
let failed = false;

function report(step, ok, extra) {
    if (!ok) failed = true;
    console.log(JSON.stringify(Object.assign({ step, ok }, extra || {})));
}

function node(id, seq, released, actions) {
    const n = net.nodes[id];
    return { nodeId: id, sequenceId: seq, released, actions: actions || [],
             nodePosition: { x: n.x, y: n.y, theta: n.theta, mapId: net.mapId } };
}

function edge(a, b, seq, released) {
    return { edgeId: `${a}-${b}`, sequenceId: seq, released, startNodeId: a, endNodeId: b, actions: [] };
}

function action(type, id, blocking) {
    return { actionType: type, actionId: id, blockingType: blocking || "HARD", actionParameters: [] };
}

function withTimeout(promise, seconds, what) {
    return Promise.race([promise, new Promise((_, reject) =>
        setTimeout(() => reject(new Error(`timed out after ${seconds} s: ${what}`)), seconds * 1000))]);
}

// Assign an order; resolves with {error, byCancelation, active, state} at onOrderProcessed.
function assign(mc, order, onEdge) {
    return new Promise((resolve, reject) => {
        mc.assignOrder(agv, order, {
            onOrderProcessed: (error, byCancelation, active, ctx) =>
                resolve({ error, byCancelation, active, state: ctx.state }),
            onEdgeTraversing: (e, s, t, changes, count, ctx) => { if (onEdge) onEdge(changes, ctx.state); },
            onActionStateChanged: (st, err, a) => console.log(JSON.stringify({ event: "action", id: a.actionId,
                                                                                  status: st.actionStatus })),
        }).catch(reject);
    });
}

// Initiate one instant action; resolves with its final state (FINISHED/FAILED) or its error.
function instant(mc, type, id) {
    return new Promise((resolve, reject) => {
        mc.initiateInstantActions(agv, { instantActions: [action(type, id, "NONE")] }, {
            onActionStateChanged: (st, err, a, id2, state) => {
                if (st.actionStatus === "FINISHED" || st.actionStatus === "FAILED") resolve({ status: st.actionStatus, state });
            },
            onActionError: (err) => resolve({ status: "ERROR", error: err }),
        }).catch(reject);
    });
}

async function main() {
    const mc = new MasterController({ interfaceName: "uagv", transport: { brokerUrl }, vdaVersion: "2.0.0" },
                                    { targetAgvs: agv });
    await mc.start();
    try {
        // 1. pick at S1, drop at Q; base S1-P, horizon P-Q released by an order update
        const o1 = mc.createUuid();
        const first = await withTimeout(assign(mc, {
            orderId: o1, orderUpdateId: 0,
            nodes: [node("S1", 0, true, [action("pick", "pick1")]), node("P", 2, true), node("Q", 4, false)],
            edges: [edge("S1", "P", 1, true), edge("P", "Q", 3, false)],
        }), 40, "the base S1-P");
        report("order base with pick", !first.error && first.active && first.state.lastNodeId === "P" &&
               first.state.loads.length === 1, { error: first.error, active: first.active,
                                                  lastNodeId: first.state.lastNodeId, loads: first.state.loads });
        const upd = await withTimeout(assign(mc, {
            orderId: o1, orderUpdateId: 1,
            nodes: [node("P", 2, true), node("Q", 4, true, [action("drop", "drop1")])],
            edges: [edge("P", "Q", 3, true)],
        }), 40, "the update P-Q");
        report("order update with drop", !upd.error && !upd.active && upd.state.lastNodeId === "Q" &&
               upd.state.loads.length === 0, { error: upd.error, active: upd.active,
                                                lastNodeId: upd.state.lastNodeId, loads: upd.state.loads });

        // 2. back Q-P-S1: pause while driving, resume, then cancel while driving
        const o2 = mc.createUuid();
        let driving, resolveDriving;
        driving = new Promise((r) => { resolveDriving = r; });
        const processed = assign(mc, {
            orderId: o2, orderUpdateId: 0,
            nodes: [node("Q", 0, true), node("P", 2, true), node("S1", 4, true)],
            edges: [edge("Q", "P", 1, true), edge("P", "S1", 3, true)],
        }, (changes, state) => { if (state.driving) resolveDriving(state); });
        await withTimeout(driving, 20, "driving on Q-P");
        const paused = await withTimeout(instant(mc, "startPause", "pause1"), 10, "startPause");
        await new Promise((r) => setTimeout(r, 1500));
        const still = await withTimeout(instant(mc, "stateRequest", "sr1"), 10, "stateRequest");
        report("startPause", paused.status === "FINISHED" && still.state.paused === true && still.state.driving === false,
               { status: paused.status, paused: still.state.paused, driving: still.state.driving });
        driving = new Promise((r) => { resolveDriving = r; });
        const resumed = await withTimeout(instant(mc, "stopPause", "resume1"), 10, "stopPause");
        const moving = await withTimeout(driving.catch(() => null).then((s) => s), 10, "driving again")
            .catch(() => null);
        report("stopPause", resumed.status === "FINISHED" && resumed.state.paused === false,
               { status: resumed.status, drivingAgain: moving !== null });
        const cancel = await withTimeout(instant(mc, "cancelOrder", "cancel1"), 20, "cancelOrder");
        const end = await withTimeout(processed, 20, "order processed after the cancel");
        report("cancelOrder", cancel.status === "FINISHED" && end.byCancelation === true && !end.active &&
               cancel.state.driving === false, { status: cancel.status, byCancelation: end.byCancelation });

        // 3. an invalid order: a node the vehicle's network does not have
        const bad = await withTimeout(assign(mc, {
            orderId: mc.createUuid(), orderUpdateId: 0,
            nodes: [node("P", 0, true), { nodeId: "NOPE", sequenceId: 2, released: true, actions: [] }],
            edges: [edge("P", "NOPE", 1, true)],
        }), 20, "the rejection");
        report("invalid order rejected", !!bad.error && bad.error.errorType === "noRouteError" && !bad.active,
               { error: bad.error });
    } catch (e) {
        report("exception", false, { error: String(e) });
    } finally {
        await mc.stop();
    }
    process.exit(failed ? 1 : 0);
}

main().catch((e) => { console.log(JSON.stringify({ step: "fatal", ok: false, error: String(e) })); process.exit(1); });
