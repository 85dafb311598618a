// A VDA 5050 2.0 master from a third party (vda-5050-lib's MasterController) giving one
// vehicle an order and saying, one JSON line each, what it hears: each node and edge
// traversed, actions' states, and the order processed (with its error, if any). Used by the
// test suite.
//
//   node vda5050_master.js BROKER_URL MANUFACTURER SERIAL MAP_ID ROUTE [SCENARIO]
//
// ROUTE: '[["a", 0, 0], ["b", 3, 1], ...]'. SCENARIO "drive" (the default): the whole route
// released, driven to its end. "lifecycle": the last node held back (the horizon) and
// released by an update once the base is done; then, driving again, a pause, a resume and a
// cancel, each waited for.
"use strict";
const { MasterController } = require("vda-5050-lib");

const [brokerUrl, manufacturer, serialNumber, mapId, route, scenario = "drive"] =
  process.argv.slice(2);
const say = (event, detail) => console.log(JSON.stringify({ event, ...detail }));

async function main() {
  const master = new MasterController({
    interfaceName: "uagv",
    transport: { brokerUrl },
    vdaVersion: "2.0.0",
  });
  await master.start();
  const agv = { manufacturer, serialNumber };
  const points = JSON.parse(route);
  const held = scenario === "lifecycle" ? 1 : 0; // nodes in the horizon at first
  const node = ([nodeId, x, y], i, released) => ({
    nodeId,
    sequenceId: 2 * i,
    released,
    nodePosition: { x, y, mapId, allowedDeviationXY: 0.5 },
    actions: [],
  });
  const edge = (a, b, released) => ({
    edgeId: `${a.nodeId}-${b.nodeId}`,
    sequenceId: a.sequenceId + 1,
    startNodeId: a.nodeId,
    endNodeId: b.nodeId,
    released,
    actions: [],
  });
  const nodes = points.map((p, i) => node(p, i, i < points.length - held));
  const edges = nodes.slice(1).map((end, i) => edge(nodes[i], end, end.released));
  const orderId = master.createUuid();
  const instant = (actionType) =>
    new Promise((resolve) => {
      const actionId = master.createUuid();
      master.initiateInstantActions(
        agv,
        { instantActions: [{ actionId, actionType, blockingType: "HARD" }] }, // 2.0's name
        {
          onActionStateChanged: (state, withError) => {
            say("action", { actionType, status: state.actionStatus, error: withError || null });
            if (state.actionStatus === "FINISHED" || state.actionStatus === "FAILED") resolve();
          },
          onActionError: (error) => {
            say("action_error", { actionType, error: String(error) });
            resolve();
          },
        },
      );
    });
  let updated = false;
  const handlers = (label) => ({
    onOrderProcessed: (withError, byCancelation, active) => {
      say("processed", { label, error: withError || null, byCancelation, active });
      if (scenario === "lifecycle" && !updated && !withError && active) {
        updated = true; // the base is done: release the rest
        const base = nodes.filter((n) => n.released);
        const rest = [base[base.length - 1], ...nodes.filter((n) => !n.released)].map(
          (n) => ({ ...n, released: true }),
        );
        const update = {
          orderId,
          orderUpdateId: 1,
          nodes: rest,
          edges: rest.slice(1).map((end, i) => edge(rest[i], end, true)),
        };
        master.assignOrder(agv, update, handlers("update")).then(() => say("updated", {}));
        return;
      }
      master.stop().then(() => process.exit(withError ? 3 : 0));
    },
    onNodeTraversed: (n) => say("node", { label, nodeId: n.nodeId }),
    onEdgeTraversing: (e, start, end, changes, count) => {
      if (scenario !== "lifecycle" || label !== "update" || count !== 1) return;
      // moving on the released rest: pause, resume, then cancel, each waited for
      instant("startPause")
        .then(() => instant("stopPause"))
        .then(() => instant("cancelOrder"));
    },
  });
  await master.assignOrder(agv, { orderId, orderUpdateId: 0, nodes, edges }, handlers("order"));
  say("assigned", { orderId });
}

main().catch((err) => {
  say("failed", { error: String(err) });
  process.exit(1);
});
