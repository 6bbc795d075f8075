// `ddsnav export --foxglove`: every derived message of the exported recording decodes against the
// schema its channel carries, that schema is Foxglove's published one (@foxglove/schemas), the
// recorded messages are copied unchanged and still decode with their OMG IDL schemas, and the views
// hold the recorded geometry.
// The Foxglove layout (configs/foxglove/ddsnav.json) names only channels such an export has.
//   node export_test.js DDSNAV_EXPORT BRIDGE_TEST_DATA SCENARIO WORKDIR LAYOUT
const fs = require("fs");
const path = require("path");
const { execFileSync } = require("child_process");
const pkg = require("./packages");
const { McapIndexedReader } = pkg["@mcap/core"];
const fzstd = pkg.fzstd;
const Ajv = pkg.ajv.default || pkg.ajv;
const { parseIDL } = pkg["@foxglove/omgidl-parser"];
const { MessageReader } = pkg["@foxglove/omgidl-serialization"];
const { check, publishedSchema, shape } = pkg;

async function open(file) {
  const data = fs.readFileSync(file);
  const readable = { size: async () => BigInt(data.length), read: async (o, s) => new Uint8Array(data.buffer, data.byteOffset + Number(o), Number(s)) };
  return McapIndexedReader.Initialize({ readable, decompressHandlers: { zstd: (b, size) => fzstd.decompress(b, new Uint8Array(Number(size))) } });
}

(async () => {
  const [exportBin, dataBin, scenario, work, layoutFile] = process.argv.slice(2);
  fs.mkdirSync(work, { recursive: true });
  const input = path.join(work, "in.mcap"), output = path.join(work, "out.mcap");
  execFileSync(dataBin, ["recording", input], { stdio: "inherit" });
  execFileSync(exportBin, ["--foxglove", "--scenario", scenario, input, output], { stdio: "inherit" });

  const ajv = new Ajv({ strict: false, allErrors: true });
  const inFile = await open(input), outFile = await open(output);
  const counts = {}, firsts = {};
  const raw = {};
  for await (const m of outFile.readMessages({ validateCrcs: true })) {
    const channel = outFile.channelsById.get(m.channelId);
    const schema = outFile.schemasById.get(channel.schemaId);
    counts[channel.topic] = (counts[channel.topic] || 0) + 1;
    if (schema.encoding === "jsonschema") {
      check(channel.messageEncoding === "json", `${channel.topic}: encoding ${channel.messageEncoding}`);
      const carried = JSON.parse(new TextDecoder().decode(schema.data));
      const published = publishedSchema(schema.name);
      check(JSON.stringify(shape(carried)) === JSON.stringify(shape(published)),
        `${channel.topic}: the carried ${schema.name} schema differs from @foxglove/schemas'`);
      const message = JSON.parse(new TextDecoder().decode(m.data));
      for (const [what, s] of [["carried", carried], ["published", published]]) {
        const validate = ajv.getSchema(what + schema.name) || (ajv.addSchema(s, what + schema.name), ajv.getSchema(what + schema.name));
        check(validate(message), `${channel.topic} message ${counts[channel.topic]} vs the ${what} ${schema.name}: ${ajv.errorsText(validate.errors)}`);
      }
      if (!firsts[channel.topic]) firsts[channel.topic] = message;
    } else {
      check(schema.encoding === "omgidl" && channel.messageEncoding === "cdr", `${channel.topic}: ${schema.encoding}/${channel.messageEncoding}`);
      const reader = raw[schema.name] || (raw[schema.name] = new MessageReader(schema.name, parseIDL(new TextDecoder().decode(schema.data))));
      reader.readMessage(m.data);  // throws on bytes that do not fit the IDL
    }
  }
  const inCounts = {};
  for await (const m of inFile.readMessages()) {
    const t = inFile.channelsById.get(m.channelId).topic;
    inCounts[t] = (inCounts[t] || 0) + 1;
  }
  for (const [t, n] of Object.entries(inCounts)) check(counts[t] === n, `${t}: ${counts[t]} copied of ${n}`);

  const expected = {
    "foxglove/scenario": 1, "foxglove/sensors/points": 6, "foxglove/perception/obstacles": 6, "foxglove/planning/path": 2,
    "foxglove/control/trajectory": 1, "foxglove/tf": 60, "foxglove/map/octomap": 1, "foxglove/map/octomap/grid": 1,
  };
  for (const [t, n] of Object.entries(expected)) check(counts[t] === n, `${t}: ${counts[t]} messages, expected ${n}`);
  check(counts["foxglove/vehicle/state"] >= 25, `foxglove/vehicle/state: ${counts["foxglove/vehicle/state"]} (about one per 0.1 s expected)`);

  const ellipse = firsts["foxglove/perception/obstacles"].entities[0].spheres[0];
  check(ellipse.size.x === 4 && ellipse.size.y === 2 && ellipse.pose.position.x === 4, "obstacle sphere " + JSON.stringify(ellipse));
  const cloud = firsts["foxglove/sensors/points"];
  const bytes = Buffer.from(cloud.data, "base64");
  check(bytes.length === 360 * 12 && Math.abs(bytes.readFloatLE(0) - 13) < 1e-5, `cloud: ${bytes.length} bytes, x0 ${bytes.readFloatLE(0)}`);
  const map = firsts["foxglove/map/octomap"].entities[0];
  check(map.cubes.length === 20, `map: ${map.cubes.length} cubes, expected the 20 occupied voxels`);
  check(firsts["foxglove/scenario"].entities[0].cubes.length === 3, "scenario: the demo yard's 3 boxes");
  // The layout: its 3D panel's topics are derived channels; the plot and table read ddsnav topics.
  const layout = JSON.parse(fs.readFileSync(layoutFile, "utf8"));
  const panels = layout.configById;
  const threeD = panels["3D!ddsnav"];
  for (const t of Object.keys(threeD.topics)) check(counts[t] > 0, `layout: 3D panel topic ${t} is not in the export`);
  const quoted = (p) => p.match(/^"([^"]+)"/)[1];
  for (const p of panels["Plot!tracking"].paths) check(quoted(p.value) === "control/tracking", "layout: plot path " + p.value);
  check(quoted(panels["Table!status"].topicPath) === "system/status" && counts["system/status"] > 0, "layout: status table");
  for (const id of [layout.layout.first, layout.layout.second.first, layout.layout.second.second]) check(panels[id], "layout: panel " + id);
  console.log("export test: " + Object.entries(counts).map(([t, n]) => `${t} ${n}`).join(", "));
})().catch((e) => {
  console.error("FAILED:", e.message);
  process.exit(1);
});
