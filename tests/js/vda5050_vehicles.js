// VDA 5050 2.0 vehicles from a third party (vda-5050-lib's AgvController driving its
// VirtualAgvAdapter) for the test suite to command with navd's fleet control. Each drives
// the orders it is given at its own speed and reports its state and position on the broker
// as a real vehicle would; this script prints one JSON line when all are online, then one
// per order a vehicle takes, and runs until killed.
//
//   node vda5050_vehicles.js BROKER_URL MAP_ID VEHICLES
//
// VEHICLES: '[["v1", 0, 0], ["v2", 0, 1.5], ...]': serial number, x and y [m] (facing +x).
"use strict";
const { AgvController, VirtualAgvAdapter } = require("vda-5050-lib");

const [brokerUrl, mapId, vehicles] = process.argv.slice(2);
const say = (event, detail) => console.log(JSON.stringify({ event, ...detail }));

async function main() {
  const controllers = JSON.parse(vehicles).map(
    ([serialNumber, x, y]) =>
      new AgvController(
        { manufacturer: "virtual", serialNumber },
        { interfaceName: "uagv", transport: { brokerUrl }, vdaVersion: "2.0.0" },
        { agvAdapterType: VirtualAgvAdapter },
        {
          initialPosition: { mapId, x, y, theta: 0, lastNodeId: "start" },
          vehicleSpeed: 0.5, // [m/s] a small robot's pace
        },
      ),
  );
  await Promise.all(controllers.map((controller) => controller.start()));
  say("ready", { vehicles: controllers.length });
}

main().catch((error) => {
  say("failed", { error: String(error) });
  process.exit(1);
});
