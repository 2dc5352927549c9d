#!/usr/bin/env node
// A 3D Tiles tileset loaded by 3d-tiles-renderer (npm) in headless Chromium
// (tiles3d_page.html), checked against a point cloud in ECEF: every tile
// with content must load without error, the number of points must match,
// and every loaded point must lie within TOLERANCE_M of a point of the
// cloud and every cloud point within TOLERANCE_M of a loaded point.
// tiles3d_browser_test.sh runs it on the fountain site's exports.
//
// Settings come from the environment, or from KEY=VALUE arguments:
//   TILESET_DIR  folder holding tileset.json and its tiles (required)
//   ECEF_PLY     the same cloud as binary PLY, double x y z (required)
//   TOLERANCE_M  largest distance allowed, metres (default 0.01)
//   TIMEOUT_S    seconds allowed for loading the tiles (default 90)
//   SCREENSHOT   PNG of the loaded tileset (default: none)
//   CHROMIUM     browser binary (default /usr/bin/chromium)
//
// Uses playwright-core, three and 3d-tiles-renderer from
// viewer/web/node_modules (npm ci --prefix viewer/web).

import fs from 'node:fs';
import path from 'node:path';
import {
  here, webRoot, requireFromViewer, log, TestFailure, fail, keyValueSettings, SOFTWARE_WEBGL_ARGS,
  serve,
} from './harness.mjs';

const { chromium } = requireFromViewer('playwright-core');

function settings() {
  const values = keyValueSettings();
  const missing = ['TILESET_DIR', 'ECEF_PLY'].filter((key) => !values[key]);
  if (missing.length) {
    console.error(`tiles3d_browser_test: missing settings: ${missing.join(', ')}`);
    process.exit(2);
  }
  const number = (key, fallback) => {
    if (values[key] === undefined || values[key] === '') return fallback;
    const n = Number(values[key]);
    if (!(n > 0)) {
      console.error(`tiles3d_browser_test: ${key} must be a positive number, not "${values[key]}"`);
      process.exit(2);
    }
    return n;
  };
  return {
    tilesetDir: path.resolve(values.TILESET_DIR),
    ecefPly: values.ECEF_PLY,
    tolerance: number('TOLERANCE_M', 0.01),
    timeoutS: number('TIMEOUT_S', 90),
    screenshot: values.SCREENSHOT || '',
    chromium: values.CHROMIUM || '/usr/bin/chromium',
  };
}

// The content URIs of a tileset's tiles, depth first (external tilesets
// are not followed: arscout writes none, and the browser would list their
// tiles too, so a count mismatch would show them).
function contentUris(tile, out = []) {
  if (tile.content) out.push(tile.content.uri);
  for (const child of tile.children || []) contentUris(child, out);
  return out;
}

// A binary little-endian PLY's vertices: x, y, z as doubles whatever the
// property types, read by the header's layout.
function readPly(file) {
  const bytes = fs.readFileSync(file);
  const endMark = 'end_header\n';
  const headerEnd = bytes.indexOf(endMark);
  if (headerEnd < 0) fail(`${file}: no end_header`);
  const header = bytes.toString('latin1', 0, headerEnd).split('\n');
  if (!header.includes('format binary_little_endian 1.0')) {
    fail(`${file}: not binary little-endian PLY`);
  }
  const sizes = { char: 1, uchar: 1, int8: 1, uint8: 1, short: 2, ushort: 2, int16: 2,
    uint16: 2, int: 4, uint: 4, int32: 4, uint32: 4, float: 4, float32: 4, double: 8,
    float64: 8 };
  const readers = {
    float: 'readFloatLE', float32: 'readFloatLE', double: 'readDoubleLE', float64: 'readDoubleLE',
  };
  let count = -1;
  let stride = 0;
  const fields = {};
  let inVertex = false;
  for (const line of header) {
    const words = line.trim().split(/\s+/);
    if (words[0] === 'element') {
      if (inVertex) break; // vertices come first in arscout's PLY files
      inVertex = words[1] === 'vertex';
      if (inVertex) count = Number(words[2]);
    } else if (words[0] === 'property' && inVertex) {
      if (words[1] === 'list' || !(words[1] in sizes)) fail(`${file}: property "${line}" not handled`);
      fields[words[2]] = { offset: stride, reader: readers[words[1]] };
      stride += sizes[words[1]];
    }
  }
  for (const axis of ['x', 'y', 'z']) {
    if (!fields[axis] || !fields[axis].reader) fail(`${file}: no float or double ${axis}`);
  }
  const body = headerEnd + endMark.length;
  if (bytes.length < body + count * stride) fail(`${file}: ${count} vertices do not fit`);
  const xyz = new Float64Array(3 * count);
  ['x', 'y', 'z'].forEach((axis, a) => {
    const { offset, reader } = fields[axis];
    for (let i = 0; i < count; ++i) xyz[3 * i + a] = bytes[reader](body + i * stride + offset);
  });
  return xyz;
}

// A uniform hash grid over points (Float64Array of xyz) with cells of
// `cell` metres, for the distance from a query to its nearest point when
// that is within `cell`. Cell coordinates are counted from the first point
// so that they stay small integers at ECEF magnitudes.
class Grid {
  constructor(xyz, cell) {
    this.xyz = xyz;
    this.cell = cell;
    this.origin = [xyz[0], xyz[1], xyz[2]];
    this.cells = new Map();
    for (let i = 0; i < xyz.length / 3; ++i) {
      const key = this.key(...this.index(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
      const list = this.cells.get(key);
      if (list) list.push(i);
      else this.cells.set(key, [i]);
    }
  }

  index(x, y, z) {
    return [Math.floor((x - this.origin[0]) / this.cell),
      Math.floor((y - this.origin[1]) / this.cell),
      Math.floor((z - this.origin[2]) / this.cell)];
  }

  // Unique while cell indices stay within +-2^16 (650 m at 1 cm cells, more
  // than a site spans): 17 bits a coordinate, 51 bits below 2^53.
  key(ix, iy, iz) {
    const span = 2 ** 17;
    const half = 2 ** 16;
    return ((ix + half) * span + (iy + half)) * span + (iz + half);
  }

  // The distance to the nearest point if one lies within one cell of the
  // query's cell, else Infinity.
  nearNearest(x, y, z) {
    const [ix, iy, iz] = this.index(x, y, z);
    if (Math.max(Math.abs(ix), Math.abs(iy), Math.abs(iz)) >= 2 ** 16 - 1) return Infinity;
    let best = Infinity;
    for (let dx = -1; dx <= 1; ++dx) {
      for (let dy = -1; dy <= 1; ++dy) {
        for (let dz = -1; dz <= 1; ++dz) {
          const list = this.cells.get(this.key(ix + dx, iy + dy, iz + dz));
          if (!list) continue;
          for (const i of list) {
            const d = Math.hypot(this.xyz[3 * i] - x, this.xyz[3 * i + 1] - y, this.xyz[3 * i + 2] - z);
            if (d < best) best = d;
          }
        }
      }
    }
    return best;
  }

  // The exact distance to the nearest point, by brute force: only for
  // reporting how far off a few points beyond the tolerance are.
  farNearest(x, y, z) {
    let best = Infinity;
    for (let i = 0; i < this.xyz.length / 3; ++i) {
      const d = Math.hypot(this.xyz[3 * i] - x, this.xyz[3 * i + 1] - y, this.xyz[3 * i + 2] - z);
      if (d < best) best = d;
    }
    return best;
  }
}

// Every point of `from` against `to`: the largest distance to a nearest
// point and the points beyond `tolerance`.
function compare(from, to, tolerance) {
  const grid = new Grid(to, tolerance);
  let worst = 0;
  let sum = 0;
  const beyond = [];
  for (let i = 0; i < from.length / 3; ++i) {
    const x = from[3 * i];
    const y = from[3 * i + 1];
    const z = from[3 * i + 2];
    let d = grid.nearNearest(x, y, z);
    if (d > tolerance) {
      if (beyond.length < 5) d = grid.farNearest(x, y, z);
      beyond.push({ i, d, at: [x, y, z] });
    }
    if (d > worst) worst = d;
    if (Number.isFinite(d)) sum += d;
  }
  return { worst, mean: sum / (from.length / 3), beyond };
}

async function main() {
  const config = settings();
  const tileset = JSON.parse(fs.readFileSync(path.join(config.tilesetDir, 'tileset.json'), 'utf8'));
  const uris = contentUris(tileset.root);
  log(`tileset.json: ${uris.length} tiles with content, version ${tileset.asset && tileset.asset.version}`);
  const ply = readPly(config.ecefPly);
  log(`${path.basename(config.ecefPly)}: ${ply.length / 3} points`);

  const server = await serve({ '/index.html': path.join(here, 'tiles3d_page.html') }, {
    '/node_modules/': path.join(webRoot, 'node_modules'),
    '/tileset/': config.tilesetDir,
  });
  const base = `http://127.0.0.1:${server.address().port}`;
  const browser = await chromium.launch({
    executablePath: config.chromium,
    headless: true,
    args: SOFTWARE_WEBGL_ARGS,
  });
  try {
    const page = await browser.newPage({ viewport: { width: 960, height: 640 } });
    const pageErrors = [];
    page.on('pageerror', (error) => pageErrors.push(error.message));
    page.on('console', (message) => {
      if (message.type() === 'error' || message.type() === 'warning') {
        console.log(`  [browser ${message.type()}] ${message.text()}`);
      }
    });
    page.on('requestfailed', (request) => console.log(`  [request failed] ${request.url()}`));
    page.on('response', (response) => {
      if (response.status() >= 400) console.log(`  [HTTP ${response.status()}] ${response.url()}`);
    });

    await page.goto(`${base}/index.html`);
    await page.waitForFunction(() => window.tilesPageReady === true, null, { timeout: 30000 })
      .catch(() => fail(`the page did not start: ${pageErrors.join('; ') || 'no error shown'}`));
    log(`page up; loading ${base}/tileset/tileset.json with 3d-tiles-renderer`);
    const result = await page.evaluate((args) => window.loadTileset(args), {
      url: `${base}/tileset/tileset.json`,
      expectTiles: uris.length,
      timeoutMs: config.timeoutS * 1000,
    });
    if (config.screenshot) await page.screenshot({ path: config.screenshot });
    log(`loaded ${result.uris.length} of ${uris.length} tiles in ${result.seconds.toFixed(1)} s ` +
        `(${result.visible} visible; objects with geometry: ${JSON.stringify(result.kinds)})`);

    if (pageErrors.length) fail(`errors in the page: ${pageErrors.join('; ')}`);
    if (result.errors.length) fail(`tiles failed to load: ${result.errors.join('; ')}`);
    if (!result.placed) fail('the root tile never loaded');
    const missing = uris.filter((uri) => !result.uris.includes(uri));
    if (missing.length) {
      fail(`${missing.length} tiles did not load in ${config.timeoutS} s, e.g. ${missing.slice(0, 5).join(', ')}`);
    }
    if (result.uris.length !== uris.length) {
      fail(`${result.uris.length} tiles loaded, the tileset has ${uris.length}`);
    }
    const kinds = Object.keys(result.kinds);
    if (kinds.length !== 1 || kinds[0] !== 'Points') {
      fail(`expected only point primitives, got ${JSON.stringify(result.kinds)}`);
    }

    const bytes = Buffer.from(result.positions, 'base64');
    const loaded = new Float64Array(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
    log(`points: ${result.count} loaded, ${ply.length / 3} in the ECEF PLY`);
    if (loaded.length !== 3 * result.count) fail('the page returned a truncated point array');
    if (result.count !== ply.length / 3) {
      fail(`${result.count} points loaded, the ECEF PLY has ${ply.length / 3}`);
    }
    const tol = config.tolerance;
    const tilesToPly = compare(loaded, ply, tol);
    const plyToTiles = compare(ply, loaded, tol);
    const mm = (metres) => (Number.isFinite(metres) ? `${(metres * 1000).toFixed(4)} mm` : 'beyond 1 cell');
    log(`loaded point to nearest PLY point: worst ${mm(tilesToPly.worst)}, mean ${mm(tilesToPly.mean)}`);
    log(`PLY point to nearest loaded point: worst ${mm(plyToTiles.worst)}, mean ${mm(plyToTiles.mean)}`);
    for (const [what, check] of [['loaded points', tilesToPly], ['PLY points', plyToTiles]]) {
      if (check.beyond.length) {
        const examples = check.beyond.slice(0, 5)
          .map(({ i, d, at }) => `#${i} at (${at.map((v) => v.toFixed(3)).join(', ')}) ${mm(d)}`);
        fail(`${check.beyond.length} ${what} lie farther than ${tol} m from the other cloud: ${examples.join('; ')}`);
      }
    }
    log(`PASS: ${result.count} points in ${uris.length} tiles within ${tol} m of the ECEF PLY ` +
        `(worst ${mm(Math.max(tilesToPly.worst, plyToTiles.worst))})`);
  } finally {
    await browser.close();
    server.close();
  }
}

main().catch((error) => {
  if (error instanceof TestFailure) console.log(`FAIL: ${error.message}`);
  else console.log(`FAIL: ${error.stack || error}`);
  process.exit(1);
});
