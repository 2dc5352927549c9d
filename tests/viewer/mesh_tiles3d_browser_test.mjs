#!/usr/bin/env node
// The 3dtiles-mesh export loaded by 3d-tiles-renderer (npm) on three.js in
// headless Chromium (tiles3d_page.html, as the point tileset's test does):
// no tile may fail, every leaf (each mesh tile's finest level) must load,
// the tiles must be meshes, every loaded vertex, placed in ECEF by the
// library's own tile transforms and glTF axis handling, must lie within
// TOLERANCE_M of a vertex of the finest levels as the engine placed them
// (a coarser level's vertices are some of the finest's), and the frame
// must show the textured surface (drawn pixels).
//
// Settings come from the environment, or from KEY=VALUE arguments:
//   TILESET_DIR   folder holding tileset.json and its tiles (required)
//   ECEF_JSON     {"vertices": [x, y, z, ...]}: the finest levels' vertices
//                 in ECEF (make_mesh_site writes it; required)
//   TOLERANCE_M   largest distance allowed, metres (default 0.01)
//   TIMEOUT_S     seconds allowed for loading the tiles (default 90)
//   SCREENSHOT    PNG of the loaded tileset (default: none)
//   CHROMIUM      browser binary (default /usr/bin/chromium)
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
  const missing = ['TILESET_DIR', 'ECEF_JSON'].filter((key) => !values[key]);
  if (missing.length) {
    console.error(`mesh_tiles3d_browser_test: missing settings: ${missing.join(', ')}`);
    process.exit(2);
  }
  return {
    tilesetDir: path.resolve(values.TILESET_DIR),
    ecefJson: values.ECEF_JSON,
    tolerance: Number(values.TOLERANCE_M || 0.01),
    timeoutS: Number(values.TIMEOUT_S || 90),
    screenshot: values.SCREENSHOT || '',
    chromium: values.CHROMIUM || '/usr/bin/chromium',
  };
}

// The content URIs of the tileset's leaves (its finest levels) and of all
// its tiles.
function contentUris(tile, out = { all: [], leaves: [] }) {
  if (tile.content) {
    out.all.push(tile.content.uri);
    if (!tile.children) out.leaves.push(tile.content.uri);
  }
  for (const child of tile.children || []) contentUris(child, out);
  return out;
}

// The largest distance from a point of `from` to its nearest in `to`
// (both flat xyz arrays), through a hash grid of `cell` metres (points
// farther than a cell count as a cell away at least).
function worstDistance(from, to, cell) {
  const key = (x, y, z) => `${Math.floor(x / cell)},${Math.floor(y / cell)},${Math.floor(z / cell)}`;
  const grid = new Map();
  for (let i = 0; i < to.length; i += 3) {
    const k = key(to[i], to[i + 1], to[i + 2]);
    if (!grid.has(k)) grid.set(k, []);
    grid.get(k).push(i);
  }
  let worst = 0;
  for (let i = 0; i < from.length; i += 3) {
    const [x, y, z] = [from[i], from[i + 1], from[i + 2]];
    const [cx, cy, cz] = [Math.floor(x / cell), Math.floor(y / cell), Math.floor(z / cell)];
    let best = Infinity;
    for (let dx = -1; dx <= 1; ++dx) {
      for (let dy = -1; dy <= 1; ++dy) {
        for (let dz = -1; dz <= 1; ++dz) {
          for (const j of grid.get(`${cx + dx},${cy + dy},${cz + dz}`) || []) {
            best = Math.min(best, Math.hypot(to[j] - x, to[j + 1] - y, to[j + 2] - z));
          }
        }
      }
    }
    worst = Math.max(worst, best);
  }
  return worst;
}

async function main() {
  const config = settings();
  const tileset = JSON.parse(fs.readFileSync(path.join(config.tilesetDir, 'tileset.json'), 'utf8'));
  const uris = contentUris(tileset.root);
  const truth = JSON.parse(fs.readFileSync(config.ecefJson, 'utf8')).vertices;
  log(`tileset.json: ${uris.all.length} tiles with content, ${uris.leaves.length} leaves; ` +
      `${truth.length / 3} finest vertices`);

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
    page.on('response', (response) => {
      if (response.status() >= 400) console.log(`  [HTTP ${response.status()}] ${response.url()}`);
    });
    await page.goto(`${base}/index.html`);
    await page.waitForFunction(() => window.tilesPageReady === true, null, { timeout: 30000 })
      .catch(() => fail(`the page did not start: ${pageErrors.join('; ') || 'no error shown'}`));
    const result = await page.evaluate((args) => window.loadTileset(args), {
      url: `${base}/tileset/tileset.json`,
      expectTiles: uris.leaves.length,
      timeoutMs: config.timeoutS * 1000,
      primitive: 'Mesh',
    });
    if (config.screenshot) await page.screenshot({ path: config.screenshot });
    log(`loaded ${result.uris.length} of ${uris.all.length} tiles in ${result.seconds.toFixed(1)} s ` +
        `(${result.visible} visible; objects with geometry: ${JSON.stringify(result.kinds)}); ` +
        `${result.drawn} of ${result.pixels} pixels drawn`);

    if (pageErrors.length) fail(`errors in the page: ${pageErrors.join('; ')}`);
    if (result.errors.length) fail(`tiles failed to load: ${result.errors.join('; ')}`);
    if (!result.placed) fail('the root tile never loaded');
    const missing = uris.leaves.filter((uri) => !result.uris.includes(uri));
    if (missing.length) fail(`leaves not loaded in ${config.timeoutS} s: ${missing.join(', ')}`);
    const kinds = Object.keys(result.kinds);
    if (kinds.length !== 1 || kinds[0] !== 'Mesh') fail(`expected only meshes, got ${JSON.stringify(result.kinds)}`);
    if (result.drawn < 0.02 * result.pixels) {
      fail(`the frame is blank: ${result.drawn} of ${result.pixels} pixels drawn`);
    }

    const bytes = Buffer.from(result.positions, 'base64');
    const loaded = new Float64Array(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
    const worst = worstDistance(loaded, truth, config.tolerance);
    log(`${result.count} loaded vertices: the farthest lies ${(worst * 1000).toFixed(3)} mm ` +
        'from a finest vertex placed by the engine');
    if (!(result.count > 0)) fail('no vertices loaded');
    if (!(worst <= config.tolerance)) fail(`a loaded vertex lies ${worst} m from every finest vertex`);
    log(`PASS: ${result.uris.length} mesh tiles loaded, ${result.count} vertices within ` +
        `${config.tolerance} m of the engine's ECEF, ${(100 * result.drawn / result.pixels).toFixed(1)} % of the frame drawn`);
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
