// Writes an MCAP file with the reference TypeScript writer (@mcap/core, uncompressed chunks), for
// reading with `ddsnav info` (docs/record.md):  node mcap_reference_write.js OUT.mcap
const fs = require("fs");
const { McapWriter } = require("@mcap/core");
(async () => {
  const chunks = []; let pos = 0n;
  const writable = { position: () => pos, write: async (b) => { chunks.push(Buffer.from(b)); pos += BigInt(b.length); } };
  const w = new McapWriter({ writable, chunkSize: 4096 });
  await w.start({ profile: "", library: "mcap-ts" });
  const schema = await w.registerSchema({ name: "ddsnav::msg::Clock", encoding: "omgidl", data: new TextEncoder().encode("struct Clock { int64 stamp_ns; };") });
  const ch = await w.registerChannel({ topic: "system/clock", schemaId: schema, messageEncoding: "cdr", metadata: new Map([["keyed", "false"]]) });
  for (let i = 0; i < 1000; i++) {
    const data = new Uint8Array(12); data[1] = 1; new DataView(data.buffer).setBigInt64(4, BigInt(i), true);
    await w.addMessage({ channelId: ch, sequence: i, logTime: BigInt(1e18) + BigInt(i) * 1000000n, publishTime: BigInt(i), data });
  }
  await w.addMetadata({ name: "test", metadata: new Map([["a", "b"]]) });
  await w.end();
  fs.writeFileSync(process.argv[2], Buffer.concat(chunks));
})();
