// Decodes a captured MAVLink byte stream with node-mavlink (an implementation the project did
// not write) and prints one JSON line per message, then a summary line:
//   node decode_mavlink.js CAPTURE.bin
// Every frame goes through node-mavlink's splitter (framing, CRC with its own CRC_EXTRA table)
// and parser, and its payload through the message class of node-mavlink's registry.
'use strict';
const fs = require('fs');
const { Readable } = require('stream');
const mavlink = require('node-mavlink');

const registry = { ...mavlink.minimal.REGISTRY, ...mavlink.common.REGISTRY };

function plain(value) {
  if (typeof value === 'bigint') return value.toString();
  if (Array.isArray(value)) return value.map(plain);
  return value;
}

const bytes = fs.readFileSync(process.argv[2]);
const splitter = new mavlink.MavLinkPacketSplitter({}, { onCrcError: () => {} });
const parser = new mavlink.MavLinkPacketParser();
let decoded = 0;
let unknown = 0;
Readable.from([bytes]).pipe(splitter).pipe(parser);
parser.on('data', (packet) => {
  const clazz = registry[packet.header.msgid];
  if (!clazz) {
    unknown += 1;
    return;
  }
  const data = packet.protocol.data(packet.payload, clazz);
  const fields = {};
  for (const f of clazz.FIELDS) {
    const v = data[f.name];
    // NaN does not survive JSON: say it in words.
    fields[f.name] = typeof v === 'number' && Number.isNaN(v) ? 'NaN'
      : Array.isArray(v) ? v.map((x) => (typeof x === 'number' && Number.isNaN(x) ? 'NaN' : plain(x))) : plain(v);
  }
  decoded += 1;
  console.log(JSON.stringify({
    msgid: packet.header.msgid, name: clazz.MSG_NAME, seq: packet.header.seq,
    sysid: packet.header.sysid, compid: packet.header.compid, fields,
  }));
});
parser.on('end', () => {
  console.log(JSON.stringify({
    summary: true, decoded, unknown, valid: splitter.validPackages,
    invalid: splitter.invalidPackages, unknown_frames: splitter.unknownPackagesCount, bytes: bytes.length,
  }));
});
