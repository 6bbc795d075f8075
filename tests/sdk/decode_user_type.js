// Reads an MCAP written by `ddsnav record` and decodes every message of TOPIC with Foxglove's OMG IDL
// reader, from the schema stored in the file only. Prints the decoded messages as JSON lines.
//   node decode_user_type.js FILE TOPIC
const fs = require("fs");
const pkg = require("../bridge/packages");
const { McapIndexedReader } = pkg["@mcap/core"];
const { parseIDL } = pkg["@foxglove/omgidl-parser"];
const { MessageReader } = pkg["@foxglove/omgidl-serialization"];
const fzstd = pkg.fzstd;

(async () => {
  const [file, topic] = process.argv.slice(2);
  const data = fs.readFileSync(file);
  const readable = { size: async () => BigInt(data.length), read: async (o, s) => new Uint8Array(data.buffer, data.byteOffset + Number(o), Number(s)) };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers: { zstd: (b, size) => fzstd.decompress(b, new Uint8Array(Number(size))) } });
  let decoder = null;
  for await (const m of reader.readMessages({ validateCrcs: true })) {
    const channel = reader.channelsById.get(m.channelId);
    if (channel.topic !== topic) continue;
    const schema = reader.schemasById.get(channel.schemaId);
    if (!schema || schema.encoding !== "omgidl") throw new Error(`${topic}: no omgidl schema in ${file}`);
    decoder = decoder || new MessageReader(schema.name, parseIDL(new TextDecoder().decode(schema.data)));
    const message = decoder.readMessage(m.data);
    console.log(JSON.stringify(message, (k, v) => (typeof v === "bigint" ? v.toString() : ArrayBuffer.isView(v) ? Array.from(v) : v)));
  }
})().catch((e) => { console.error(`decode_user_type: ${e.stack || e}`); process.exit(1); });
