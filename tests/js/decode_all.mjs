// Decodes every message of an MCAP file with Foxglove's TypeScript libraries (@mcap/core reads
// the records, @foxglove/rosmsg parses each channel's ros2msg schema, and
// @foxglove/rosmsg2-serialization builds the CDR decoder from it): a reader independent of the
// project's Rust code and of the Python readers. Prints the message count per topic and the
// first decoded message of each as JSON; exits 1 if a message does not decode, 2 on bad use.
//
//     node tests/js/decode_all.mjs FILE.mcap

import { readFileSync } from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompress } from "fzstd";

const path = process.argv[2];
if (!path) {
  console.error("usage: node decode_all.mjs FILE.mcap");
  process.exit(2);
}

const reader = new McapStreamReader({
  decompressHandlers: {
    zstd: (data, size) => {
      const out = decompress(data, new Uint8Array(Number(size)));
      if (out.byteLength !== Number(size)) {
        throw new Error(`zstd chunk of ${out.byteLength} bytes, its record says ${size}`);
      }
      return out;
    },
  },
});
reader.append(readFileSync(path));

const schemas = new Map();
const channels = new Map();
const readers = new Map();
const counts = {};
const first = {};
let failed = 0;
for (let record; (record = reader.nextRecord()) !== undefined; ) {
  if (record.type === "Schema") {
    schemas.set(record.id, record);
  } else if (record.type === "Channel") {
    channels.set(record.id, record);
    const schema = schemas.get(record.schemaId);
    if (!schema || schema.encoding !== "ros2msg" || record.messageEncoding !== "cdr") {
      console.error(`${record.topic}: schema ${schema?.encoding}, messages ${record.messageEncoding}: not ROS 2`);
      failed += 1;
      continue;
    }
    const text = new TextDecoder().decode(schema.data);
    readers.set(record.id, new MessageReader(parse(text, { ros2: true })));
  } else if (record.type === "Message") {
    const channel = channels.get(record.channelId);
    const decoder = readers.get(record.channelId);
    if (!channel || !decoder) {
      failed += 1;
      continue;
    }
    try {
      const msg = decoder.readMessage(record.data);
      counts[channel.topic] = (counts[channel.topic] ?? 0) + 1;
      if (!(channel.topic in first)) {
        first[channel.topic] = msg;
      }
    } catch (e) {
      console.error(`${channel.topic}: message at ${record.logTime} ns does not decode: ${e.message}`);
      failed += 1;
    }
  }
}
if (!reader.done()) {
  console.error(`${path}: the file ends inside a record (cut off?)`);
  failed += 1;
}
const json = JSON.stringify({ counts, first }, (_, v) => {
  if (typeof v === "bigint") return Number(v);
  if (ArrayBuffer.isView(v)) return Array.from(v);
  return v;
});
console.log(json);
process.exit(failed > 0 ? 1 : 0);
