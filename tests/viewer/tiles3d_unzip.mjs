#!/usr/bin/env node
// Extracts the 3dtiles export (a zip) into a folder, for the 3D Tiles tests
// (tiles3d_support.sh). Written here rather than calling unzip(1) because
// deploy/install-deps.sh does not install it, and because reading the zip
// ourselves lets the tests check what a client relies on: every entry's
// CRC-32 and sizes agree between the central directory and the data.
//   node tiles3d_unzip.mjs ZIP OUT_DIR
// Handles stored (method 0, what arscout writes) and deflated entries.

import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';

function fail(message) {
  console.error(`tiles3d_unzip: ${message}`);
  process.exit(1);
}

// CRC-32 (IEEE, reflected, polynomial 0xEDB88320) as zip uses it; Node 18
// (Debian 12's) has no zlib.crc32.
const crcTable = new Uint32Array(256);
for (let n = 0; n < 256; ++n) {
  let c = n;
  for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  crcTable[n] = c >>> 0;
}
function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

const [zipPath, outDir] = process.argv.slice(2);
if (!zipPath || !outDir) {
  console.error('usage: node tiles3d_unzip.mjs ZIP OUT_DIR');
  process.exit(2);
}
const zip = fs.readFileSync(zipPath);

// The end-of-central-directory record is the last 22 bytes plus an
// optional comment of up to 64 KiB: search backwards for its signature.
let end = -1;
for (let at = zip.length - 22; at >= Math.max(0, zip.length - 22 - 0xffff); --at) {
  if (zip.readUInt32LE(at) === 0x06054b50) {
    end = at;
    break;
  }
}
if (end < 0) fail(`${zipPath}: no end of central directory (not a zip?)`);
const entries = zip.readUInt16LE(end + 10);
let at = zip.readUInt32LE(end + 16);

const root = path.resolve(outDir);
const names = [];
for (let i = 0; i < entries; ++i) {
  if (zip.readUInt32LE(at) !== 0x02014b50) fail(`entry ${i}: bad central directory header`);
  const method = zip.readUInt16LE(at + 10);
  const crc = zip.readUInt32LE(at + 16);
  const packedSize = zip.readUInt32LE(at + 20);
  const size = zip.readUInt32LE(at + 24);
  const nameLength = zip.readUInt16LE(at + 28);
  const extraLength = zip.readUInt16LE(at + 30);
  const commentLength = zip.readUInt16LE(at + 32);
  const localAt = zip.readUInt32LE(at + 42);
  const name = zip.toString('utf8', at + 46, at + 46 + nameLength);
  at += 46 + nameLength + extraLength + commentLength;

  // A name must stay inside OUT_DIR: no absolute paths, no "..".
  const target = path.resolve(root, name);
  if (path.isAbsolute(name) || !target.startsWith(root + path.sep)) {
    fail(`entry "${name}" would land outside ${outDir}`);
  }
  if (name.endsWith('/')) {
    fs.mkdirSync(target, { recursive: true });
    continue;
  }

  if (zip.readUInt32LE(localAt) !== 0x04034b50) fail(`${name}: bad local header`);
  const dataAt = localAt + 30 + zip.readUInt16LE(localAt + 26) + zip.readUInt16LE(localAt + 28);
  const packed = zip.subarray(dataAt, dataAt + packedSize);
  let data;
  if (method === 0) data = packed;
  else if (method === 8) data = zlib.inflateRawSync(packed);
  else fail(`${name}: compression method ${method} is not handled`);
  if (data.length !== size) fail(`${name}: ${data.length} bytes, the directory says ${size}`);
  if (crc32(data) !== crc) fail(`${name}: CRC-32 mismatch`);

  fs.mkdirSync(path.dirname(target), { recursive: true });
  fs.writeFileSync(target, data);
  names.push(name);
}
console.log(`extracted ${names.length} files from ${path.basename(zipPath)} into ${outDir}`);
