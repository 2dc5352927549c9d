// Writes the app's icons (icon-192.png, icon-512.png) with Node's zlib only:
// a dark square, a white camera aperture ring and a blue dot, the scout's
// mark. Run: node viewer/web/scout/icons/make_icons.mjs
import { writeFileSync } from 'node:fs';
import { deflateSync } from 'node:zlib';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));

const CRC_TABLE = Array.from({ length: 256 }, (_, n) => {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});

function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = CRC_TABLE[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

function chunk(type, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(type, 4, 'latin1');
  data.copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}

/** RGB of the icon at (x, y) of a size x size square, antialiased 4x4. */
function colour(x, y, size) {
  const sum = [0, 0, 0];
  for (let j = 0; j < 4; j++) {
    for (let i = 0; i < 4; i++) {
      const u = (x + (i + 0.5) / 4) / size - 0.5;
      const v = (y + (j + 0.5) / 4) / size - 0.5;
      const r = Math.hypot(u, v);
      let c = [11, 15, 20];
      if (r > 0.26 && r < 0.33) c = [230, 233, 238];
      if (r < 0.12) c = [74, 168, 255];
      for (let k = 0; k < 3; k++) sum[k] += c[k];
    }
  }
  return sum.map((s) => Math.round(s / 16));
}

function png(size) {
  const raw = Buffer.alloc(size * (1 + 3 * size));
  for (let y = 0; y < size; y++) {
    const row = y * (1 + 3 * size);
    raw[row] = 0; // no filter
    for (let x = 0; x < size; x++) {
      const [r, g, b] = colour(x, y, size);
      raw.set([r, g, b], row + 1 + 3 * x);
    }
  }
  const header = Buffer.alloc(13);
  header.writeUInt32BE(size, 0);
  header.writeUInt32BE(size, 4);
  header.set([8, 2, 0, 0, 0], 8); // 8-bit RGB
  return Buffer.concat([
    Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk('IHDR', header),
    chunk('IDAT', deflateSync(raw, { level: 9 })),
    chunk('IEND', Buffer.alloc(0)),
  ]);
}

for (const size of [192, 512]) writeFileSync(join(here, `icon-${size}.png`), png(size));
