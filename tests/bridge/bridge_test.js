// `ddsnav bridge` end to end: a publisher on a test domain, the bridge, Foxglove's own client
// (@foxglove/ws-protocol). Checks: raw perception/obstacles decodes with the advertised OMG IDL, the
// derived SceneUpdate validates against Foxglove's published schema, bad client input gets an error status
// while another client keeps receiving, a client without the subprotocol is refused, a taken port is an
// error naming it, and a topic whose publisher ends is unadvertised.
//   node bridge_test.js DDSNAV_BRIDGE BRIDGE_TEST_DATA DOMAIN SCENARIO
const { spawn } = require("child_process");
const pkg = require("./packages");
const WebSocket = pkg.ws;
const { FoxgloveClient } = pkg["@foxglove/ws-protocol"];
const Ajv = pkg.ajv.default || pkg.ajv;
const { parseIDL } = pkg["@foxglove/omgidl-parser"];
const { MessageReader } = pkg["@foxglove/omgidl-serialization"];
const { check, publishedSchema } = pkg;

const [bridgeBin, dataBin, domain, scenario] = process.argv.slice(2);
const children = [];
function start(bin, args) {
  const child = spawn(bin, args, { env: { ...process.env, DDSNAV_DOMAIN: domain }, stdio: ["ignore", "pipe", "pipe"] });
  child.out = "";
  child.err = "";
  child.stdout.on("data", (d) => (child.out += d));
  child.stderr.on("data", (d) => (child.err += d));
  child.exited = new Promise((resolve) => child.on("exit", (code, signal) => resolve({ code, signal })));
  children.push(child);
  return child;
}
async function until(what, cond, ms = 20000) {
  const end = Date.now() + ms;
  while (!cond()) {
    if (Date.now() > end) throw new Error("timed out waiting for " + what);
    await new Promise((r) => setTimeout(r, 20));
  }
}

(async () => {
  const data = start(dataBin, ["publish", "--domain", domain]);
  await until("the publisher", () => data.out.includes("ready"));
  const bridge = start(bridgeBin, ["--port", "0", "--scenario", scenario, "--stats-interval", "0"]);
  await until("the bridge to listen", () => /listening on ws:\/\/127\.0\.0\.1:(\d+)/.test(bridge.out));
  const port = Number(bridge.out.match(/listening on ws:\/\/127\.0\.0\.1:(\d+)/)[1]);
  const url = `ws://127.0.0.1:${port}`;

  // Client A: Foxglove's client library.
  const a = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const channels = new Map(), gone = new Set(), aStatus = [];
  let serverInfo = null;
  a.on("serverInfo", (i) => (serverInfo = i));
  a.on("advertise", (cs) => cs.forEach((c) => channels.set(c.topic, c)));
  a.on("unadvertise", (ids) => ids.forEach((id) => gone.add(id)));
  a.on("status", (s) => aStatus.push(s));
  const byTopic = () => Object.fromEntries([...channels.values()].map((c) => [c.topic, c]));
  await until("advertised obstacles, their view and the scenario",
    () => ["perception/obstacles", "foxglove/perception/obstacles", "foxglove/scenario", "foxglove/tf"].every((t) => byTopic()[t]));
  check(serverInfo && serverInfo.name === "ddsnav bridge", "serverInfo " + JSON.stringify(serverInfo));
  const rawChannel = byTopic()["perception/obstacles"], viewChannel = byTopic()["foxglove/perception/obstacles"];
  check(rawChannel.encoding === "cdr" && rawChannel.schemaEncoding === "omgidl" && rawChannel.schemaName === "ddsnav::msg::ObstacleArray",
    "raw channel " + JSON.stringify({ ...rawChannel, schema: undefined }));
  check(viewChannel.encoding === "json" && viewChannel.schemaEncoding === "jsonschema" && viewChannel.schemaName === "foxglove.SceneUpdate",
    "view channel " + JSON.stringify({ ...viewChannel, schema: undefined }));

  const reader = new MessageReader(rawChannel.schemaName, parseIDL(rawChannel.schema));
  const ajv = new Ajv({ strict: false, allErrors: true });
  const validateScene = ajv.compile(publishedSchema("foxglove.SceneUpdate"));
  const subs = new Map();
  const received = { raw: 0, view: 0, tf: 0 };
  let rawSample = null, viewSample = null;
  a.on("message", ({ subscriptionId, data }) => {
    const topic = subs.get(subscriptionId);
    if (topic === "perception/obstacles") {
      rawSample = reader.readMessage(data);
      received.raw++;
    } else if (topic === "foxglove/perception/obstacles") {
      viewSample = JSON.parse(new TextDecoder().decode(data));
      check(validateScene(viewSample), "SceneUpdate vs @foxglove/schemas: " + ajv.errorsText(validateScene.errors));
      received.view++;
    } else if (topic === "foxglove/tf") received.tf++;
  });
  for (const t of ["perception/obstacles", "foxglove/perception/obstacles", "foxglove/tf"]) subs.set(a.subscribe(byTopic()[t].id), t);
  await until("obstacles, raw and as a scene", () => received.raw >= 1 && received.view >= 1 && received.tf >= 5);
  const o = rawSample.obstacles[0];
  check(o.id === 7 && o.centre.x === 4 && o.centre.y === 5 && o.probability_bound === 0.99 && rawSample.planar === true,
    "raw obstacle " + JSON.stringify(o));
  const sphere = viewSample.entities[0].spheres[0];
  check(sphere.size.x === 4 && sphere.size.y === 2 && Math.abs(sphere.pose.orientation.z - Math.sin(0.25)) < 1e-12, "scene sphere " + JSON.stringify(sphere));
  check(viewSample.entities[0].metadata.some((kv) => kv.key === "probability_bound" && kv.value === "0.9900"), "probability in metadata");

  // Client B: a plain WebSocket sending bad input; each gets an error status, the bridge goes on.
  const b = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const bStatus = [];
  b.on("message", (d, binary) => {
    if (binary) return;
    const m = JSON.parse(d.toString());
    if (m.op === "status") bStatus.push(m);
  });
  await new Promise((r, j) => (b.once("open", r), b.once("error", j)));
  const expectError = async (send, pattern) => {
    const before = bStatus.length;
    send();
    await until(`an error status matching ${pattern}`, () => bStatus.slice(before).some((s) => s.level === 2 && pattern.test(s.message)));
  };
  await expectError(() => b.send("{not json"), /malformed JSON/);
  await expectError(() => b.send(JSON.stringify({ op: "fly" })), /unknown op "fly"/);
  await expectError(() => b.send(JSON.stringify({ nop: 1 })), /field "op"/);
  await expectError(() => b.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 1, channelId: 999999 }] })), /unknown channel id 999999/);
  await expectError(() => b.send(JSON.stringify({ op: "subscribe", subscriptions: "all" })), /must be an array/);
  await expectError(() => b.send(Buffer.from([0x07, 1, 2, 3])), /opcode 7/);
  await expectError(() => b.send(JSON.stringify({ op: "advertise", channels: [] })), /capability/);
  // A flood: 3000 subscribe requests, 2 subscriptions each, to a real channel.
  const tfId = byTopic()["foxglove/tf"].id;
  const floodStart = bStatus.length;
  for (let i = 0; i < 3000; i++) b.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 2 * i + 10, channelId: tfId }, { id: 2 * i + 11, channelId: tfId }] }));
  await until("the subscription limit", () => bStatus.slice(floodStart).some((s) => s.level === 2 && /more than 1024 subscriptions/.test(s.message)));
  const rawBefore = received.tf;
  await until("client A still served after the flood", () => received.tf >= rawBefore + 10);
  check(b.readyState === WebSocket.OPEN, "client B still connected");

  // No subprotocol: refused with HTTP 400.
  const refused = await new Promise((resolve) => {
    const c = new WebSocket(url);
    c.on("unexpected-response", (_req, res) => resolve(res.statusCode));
    c.on("open", () => resolve("opened"));
    c.on("error", () => {});
  });
  check(refused === 400, "a client without the subprotocol got " + refused);

  // The port taken: a clear error naming it.
  const second = start(bridgeBin, ["--port", String(port)]);
  const secondExit = await second.exited;
  check(secondExit.code === 1 && second.err.includes(`127.0.0.1:${port}`) && /in use/.test(second.err),
    `second bridge on a taken port: exit ${JSON.stringify(secondExit)}, stderr ${second.err}`);

  // The publisher ends: its topics are unadvertised.
  data.kill("SIGTERM");
  await data.exited;
  await until("perception/obstacles unadvertised", () => gone.has(rawChannel.id) && gone.has(viewChannel.id), 15000);

  a.close();
  b.close();
  bridge.kill("SIGTERM");
  const bridgeExit = await bridge.exited;
  check(bridgeExit.code === 0, "bridge exit " + JSON.stringify(bridgeExit) + " " + bridge.err);
  console.log(`bridge test: raw ${received.raw}, scene ${received.view}, tf ${received.tf}; ${bStatus.length} error statuses to client B`);
})()
  .catch((e) => {
    console.error("FAILED:", e.message);
    for (const c of children) if (c.err) console.error("--- stderr of", c.spawnargs.join(" "), "\n" + c.err.slice(-3000));
    process.exitCode = 1;
  })
  .finally(() => {
    for (const c of children) if (c.exitCode === null && c.signalCode === null) c.kill("SIGKILL");
    setTimeout(() => process.exit(), 100);
  });
