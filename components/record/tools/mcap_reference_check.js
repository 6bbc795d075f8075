// Cross-check of ddsnav MCAP files against the reference TypeScript implementation (@mcap/core), by hand:
//   cd /tmp/mcapcheck && npm install @mcap/core fzstd lz4js && node <ddsnav>/components/record/tools/mcap_reference_check.js FILE.mcap
// (run from the folder holding node_modules, or set NODE_PATH). See docs/record.md.
const fs = require("fs");
const { McapStreamReader, McapIndexedReader } = require("@mcap/core");
const fzstd = require("fzstd");
const decompressHandlers = { zstd: (buf, size) => fzstd.decompress(buf, new Uint8Array(Number(size))) };
// lz4 chunks (LZ4 frames), when lz4js is installed: an independent decoder of the frame format.
try {
  const lz4js = require("lz4js");
  decompressHandlers.lz4 = (buf, size) => Uint8Array.from(lz4js.decompress(buf, Number(size)));
} catch (e) {}
(async () => {
  const path = process.argv[2];
  const data = fs.readFileSync(path);
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true, includeChunks: true });
  stream.append(new Uint8Array(data));
  const counts = {};
  for (let r; (r = stream.nextRecord()); ) counts[r.type] = (counts[r.type] || 0) + 1;
  console.log("stream:", JSON.stringify(counts), "done:", stream.done());
  const readable = { size: async () => BigInt(data.length), read: async (o, s) => new Uint8Array(data.buffer, data.byteOffset + Number(o), Number(s)) };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  let n = 0, last = 0n, bytes = 0;
  for await (const m of reader.readMessages({ validateCrcs: true })) { if (m.logTime < last) throw new Error("order"); last = m.logTime; n++; bytes += m.data.length; }
  console.log("indexed: messages", n, "bytes", bytes, "chunks", reader.chunkIndexes.length, "channels", reader.channelsById.size,
              "schemas", reader.schemasById.size, "stats", reader.statistics && reader.statistics.messageCount.toString(),
              "metadata", reader.metadataIndexes.length);
})().catch((e) => { console.error("FAILED:", e.message); process.exit(1); });
