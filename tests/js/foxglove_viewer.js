// A live-view client from a third party (@foxglove/ws-protocol's FoxgloveClient over the
// `ws` package, asking for the protocol by its first name, foxglove.websocket.v1, as
// Lichtblick before December 2025 does) that subscribes to TOPIC and says, one JSON line
// each, what it sees: the server's name, the topics advertised, each message's size.
// Used by the test suite.
//
//   node foxglove_viewer.js ws://127.0.0.1:PORT TOPIC MESSAGES
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { WebSocket } = require("ws");

const [url, topic, wanted] = process.argv.slice(2);
const say = (event, detail) => console.log(JSON.stringify({ event, ...detail }));

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
ws.on("unexpected-response", (_request, response) => {
  say("refused", { status: response.statusCode });
  process.exit(2);
});
const client = new FoxgloveClient({ ws });
let subscription = null;
let received = 0;
client.on("open", () => say("open", { protocol: ws.protocol }));
client.on("serverInfo", (info) => say("serverInfo", { name: info.name }));
client.on("advertise", (channels) => {
  say("advertise", { topics: channels.map((c) => c.topic) });
  const channel = channels.find((c) => c.topic === topic);
  if (channel && subscription === null) subscription = client.subscribe(channel.id);
});
client.on("message", ({ subscriptionId, data }) => {
  if (subscriptionId !== subscription) return;
  received += 1;
  say("message", { topic, bytes: data.byteLength });
  if (received >= Number(wanted)) {
    client.close();
    process.exit(0);
  }
});
client.on("error", (err) => say("error", { error: String(err) }));
setTimeout(() => { say("timeout", { received }); process.exit(1); }, 30000);
