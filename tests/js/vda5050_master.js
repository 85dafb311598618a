// A VDA 5050 2.0 master from a third party (vda-5050-lib's MasterController) giving one
// order to one vehicle and saying, one JSON line each, what it hears: each node and edge
// traversed, and the order processed (with its error, if any). Used by the test suite.
//
//   node vda5050_master.js BROKER_URL MANUFACTURER SERIAL MAP_ID '[["a", 0, 0], ["b", 3, 1]]'
"use strict";
const { MasterController } = require("vda-5050-lib");

const [brokerUrl, manufacturer, serialNumber, mapId, route] = process.argv.slice(2);
const say = (event, detail) => console.log(JSON.stringify({ event, ...detail }));

async function main() {
  const master = new MasterController({
    interfaceName: "uagv",
    transport: { brokerUrl },
    vdaVersion: "2.0.0",
  });
  await master.start();
  const points = JSON.parse(route);
  const nodes = points.map(([nodeId, x, y], i) => ({
    nodeId,
    sequenceId: 2 * i,
    released: true,
    nodePosition: { x, y, mapId, allowedDeviationXY: 0.5 },
    actions: [],
  }));
  const edges = nodes.slice(1).map((end, i) => ({
    edgeId: `${nodes[i].nodeId}-${end.nodeId}`,
    sequenceId: 2 * i + 1,
    startNodeId: nodes[i].nodeId,
    endNodeId: end.nodeId,
    released: true,
    actions: [],
  }));
  const order = { orderId: master.createUuid(), orderUpdateId: 0, nodes, edges };
  await master.assignOrder({ manufacturer, serialNumber }, order, {
    onOrderProcessed: (withError, byCancelation, active) => {
      say("processed", { error: withError || null, byCancelation, active });
      master.stop().then(() => process.exit(withError ? 3 : 0));
    },
    onNodeTraversed: (node) => say("node", { nodeId: node.nodeId }),
    onEdgeTraversed: (edge) => say("edge", { edgeId: edge.edgeId }),
  });
  say("assigned", { orderId: order.orderId });
}

main().catch((err) => {
  say("failed", { error: String(err) });
  process.exit(1);
});
