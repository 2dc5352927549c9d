#!/usr/bin/env node
// The web viewer's mesh mode (docs/viewer.md, "Mesh") in headless Chromium
// with software WebGL, on the fountain-P11 site of the viewer_fountain
// fixture (built with the engine's --mesh):
//
// 1. The points / mesh / both switch is shown (the model has a mesh), and
//    "both" draws points and triangles.
// 2. Streaming: each tile's first level fetched is its coarsest; from far
//    away every tile shows its coarsest level, and close to the surface the
//    tile there shows a finer one than from far.
// 3. A new model version naming the same mesh blobs (an admin's patch of
//    the model document, seen through the live feed) takes the levels
//    over: the new version's mesh is shown without fetching a level again.
// 4. The reference view: the model seen from a registered photo's pose
//    ("view from"), eye-dome lighting and frusta off, drawn as points and
//    then as the mesh. Over the photo's rectangle on the canvas:
//    - not blank: the mesh covers at least MIN_COVERED of it;
//    - the fountain visible: on a grid of CELL_PX cells, the mesh's grey
//      levels correlate (ZNCC) with the points' rendering of the same view
//      (the dense cloud through its own octree and shader: an independent
//      path) by at least MIN_ZNCC_POINTS, and with the photo itself (one
//      of those that textured the mesh: not held out) by at least
//      MIN_ZNCC_PHOTO, while the photo mirrored left to right (the same
//      colours in the wrong places) stays below MAX_ZNCC_MIRRORED.
//
// Settings from the environment:
//   SERVER, PLANNER_TOKEN   the server and a planner token (required)
//   ADMIN_TOKEN             an admin token for step 3 (skipped without)
//   SITE_ID                 the site (default: the only one listed)
//   CAPTURE                 the photo whose pose is the reference view
//                           (default: the middle registered one)
//   MIN_COVERED (0.6), CELL_PX (16), MIN_ZNCC_POINTS (0.7),
//   MIN_ZNCC_PHOTO (0.8), MAX_ZNCC_MIRRORED (0.4)
//   SCREENSHOT              PNG of the mesh from the reference view
//   CHROMIUM                browser binary (default /usr/bin/chromium)
// Prints one JSON line of figures ("figures: {...}").

import { requireFromViewer, log, TestFailure, fail, SOFTWARE_WEBGL_ARGS } from './harness.mjs';
import { settleView } from './viewer_page.mjs';

const { chromium } = requireFromViewer('playwright-core');

const env = process.env;
const config = {
  server: (env.SERVER || '').replace(/\/+$/, ''),
  token: env.PLANNER_TOKEN || '',
  adminToken: env.ADMIN_TOKEN || '',
  siteId: env.SITE_ID || '',
  capture: env.CAPTURE || '',
  minCovered: Number(env.MIN_COVERED || 0.6),
  cellPx: Number(env.CELL_PX || 16),
  minZnccPoints: Number(env.MIN_ZNCC_POINTS || 0.7),
  minZnccPhoto: Number(env.MIN_ZNCC_PHOTO || 0.8),
  maxZnccMirrored: Number(env.MAX_ZNCC_MIRRORED || 0.4),
  screenshot: env.SCREENSHOT || '',
  chromium: env.CHROMIUM || '/usr/bin/chromium',
};
if (!config.server || !config.token) {
  console.error('mesh_browser_test: SERVER and PLANNER_TOKEN are required');
  process.exit(2);
}

async function signIn(page) {
  await page.goto(`${config.server}/`, { waitUntil: 'load' });
  await page.waitForSelector('#token-input', { state: 'visible', timeout: 30000 });
  await page.fill('#token-input', config.token);
  await page.click('#token-submit');
  await page.waitForSelector('tr[data-site]', { timeout: 60000 });
  let site = config.siteId;
  if (!site) {
    const ids = await page.$$eval('tr[data-site]', (rows) => rows.map((r) => r.dataset.site));
    if (ids.length !== 1) fail(`SITE_ID not given and the list shows ${ids.length} sites`);
    site = ids[0];
  }
  await page.click(`tr[data-site=${JSON.stringify(site)}]`);
  await page.waitForSelector('body[data-cloud="loaded"]', { timeout: 300000 });
  log(`opened site ${site}`);
  return site;
}

/** Renders until the mesh shows a level of every tile and wants no other. */
async function settleMesh(page) {
  await page.waitForFunction(() => {
    const { viewer } = window.arscoutViewer;
    viewer.renderNow();
    const mesh = viewer.mesh;
    return mesh && mesh.settled && mesh.shownTiles === mesh.tiles.length;
  }, null, { timeout: 300000, polling: 250 });
  return page.evaluate(() => {
    const { mesh } = window.arscoutViewer.viewer;
    return {
      triangles: mesh.drawnTriangles,
      shown: Object.fromEntries(mesh.tiles.map((t) => [t.name, t.shown])),
      coarsest: Object.fromEntries(mesh.tiles.map((t) => [t.name, t.levels.length - 1])),
    };
  });
}

async function choose(page, id) {
  await page.check(id);
  await page.evaluate(() => window.arscoutViewer.viewer.renderNow());
}

/**
 * The view as cells of `cellPx` over the photo's rectangle on the canvas
 * (the view-from camera's: the photo's rows span the canvas's height, as
 * the view's vertical field of view is the photo's, its principal point at
 * the canvas's centre): per cell the share of its pixels drawn (not the
 * background) and the mean grey of those; with `withPhoto`, the photo's
 * and its mirror image's cells (every pixel) too, drawn into the same
 * rectangle. `covered`: the share of the rectangle's pixels drawn.
 */
async function readView(page, capture, cellPx, withPhoto) {
  return page.evaluate(async ([id, cell, photo]) => {
    const { viewer, state } = window.arscoutViewer;
    viewer.renderNow();
    const source = viewer.canvas;
    const width = source.width, height = source.height;
    const scratch = document.createElement('canvas');
    scratch.width = width;
    scratch.height = height;
    const context = scratch.getContext('2d', { willReadFrequently: true });
    const attrs = state.model.attrs;
    const image = attrs.images.find((im) => im.id === id);
    const camera = typeof image.camera === 'number'
      ? attrs.cameras[image.camera] : attrs.cameras.find((c) => c.id === image.camera);
    const s = height / camera.height;
    const sx = s * (camera.fy / camera.fx);
    const rect = { x: width / 2 - camera.cx * sx, y: height / 2 - camera.cy * s, w: camera.width * sx, h: camera.height * s };
    const x0 = Math.max(0, Math.ceil(rect.x)), x1 = Math.min(width, Math.floor(rect.x + rect.w));
    const y0 = Math.max(0, Math.ceil(rect.y)), y1 = Math.min(height, Math.floor(rect.y + rect.h));
    const background = [0x16, 0x18, 0x1c];
    // Cells of what `draw` puts on the scratch canvas.
    const cellsOf = (draw, everyPixel) => {
      context.fillStyle = '#000';
      context.fillRect(0, 0, width, height);
      draw();
      const px = context.getImageData(0, 0, width, height).data;
      const out = [];
      let drawnAll = 0;
      for (let cy = y0; cy + cell <= y1; cy += cell) {
        for (let cx = x0; cx + cell <= x1; cx += cell) {
          let n = 0, sum = 0;
          for (let y = cy; y < cy + cell; y++) {
            for (let x = cx; x < cx + cell; x++) {
              const i = 4 * (y * width + x);
              const drawn = Math.abs(px[i] - background[0]) + Math.abs(px[i + 1] - background[1]) +
                Math.abs(px[i + 2] - background[2]) > 12;
              if (!everyPixel && !drawn) continue;
              n++;
              sum += 0.299 * px[i] + 0.587 * px[i + 1] + 0.114 * px[i + 2];
            }
          }
          drawnAll += n;
          out.push({ covered: n / (cell * cell), grey: n ? sum / n : 0 });
        }
      }
      return { cells: out, covered: drawnAll / Math.max(1, out.length * cell * cell) };
    };
    const view = cellsOf(() => context.drawImage(source, 0, 0), false);
    if (!photo) return { view };
    const response = await fetch(`/v1/captures/${encodeURIComponent(id)}/thumbnail.jpg?size=1024`, {
      headers: { Authorization: `Bearer ${sessionStorage.getItem('arscout.token')}` },
    });
    const bitmap = await createImageBitmap(await response.blob());
    const straight = cellsOf(() => context.drawImage(bitmap, rect.x, rect.y, rect.w, rect.h), true);
    const mirrored = cellsOf(() => {
      context.save();
      context.translate(2 * rect.x + rect.w, 0);
      context.scale(-1, 1);
      context.drawImage(bitmap, rect.x, rect.y, rect.w, rect.h);
      context.restore();
    }, true);
    return { view, photo: straight, mirrored };
  }, [capture, cellPx, withPhoto]);
}

/** Zero-mean normalised cross-correlation of two cell lists where both are mostly drawn. */
function zncc(a, b) {
  const pairs = [];
  for (let i = 0; i < a.length; i++) {
    if (a[i].covered >= 0.5 && b[i].covered >= 0.5) pairs.push([a[i].grey, b[i].grey]);
  }
  const n = pairs.length;
  if (n < 10) return { zncc: NaN, cells: n };
  const ma = pairs.reduce((s, p) => s + p[0], 0) / n;
  const mb = pairs.reduce((s, p) => s + p[1], 0) / n;
  let sab = 0, saa = 0, sbb = 0;
  for (const [x, y] of pairs) {
    sab += (x - ma) * (y - mb);
    saa += (x - ma) ** 2;
    sbb += (y - mb) ** 2;
  }
  return { zncc: sab / Math.sqrt(saa * sbb), cells: n };
}

/** The registered capture in the middle of the list (by id), or CAPTURE. */
async function referenceCapture(page) {
  if (config.capture) return config.capture;
  const ids = await page.$$eval('tr.capture-status[data-status="registered"]',
    (rows) => rows.map((r) => r.dataset.capture));
  if (ids.length === 0) fail('no registered capture to view from');
  ids.sort();
  return ids[Math.floor(ids.length / 2)];
}

/** Far away every tile shows its coarsest level; close up a finer one. */
async function checkStreaming(page, firstLevels) {
  const far = await page.evaluate(() => {
    const { viewer } = window.arscoutViewer;
    const { home } = viewer;
    const away = home.position.clone().sub(home.target).multiplyScalar(20);
    viewer.camera.position.copy(home.target).add(away);
    viewer.controls.target.copy(home.target);
    viewer.controls.update();
  }).then(() => settleMesh(page));
  for (const [tile, level] of Object.entries(far.shown)) {
    if (level !== far.coarsest[tile]) fail(`from far away tile ${tile} shows level ${level}, not its coarsest ${far.coarsest[tile]}`);
  }
  // A metre from the surface at the middle of the photo's view.
  const near = await page.evaluate(() => {
    const { viewer } = window.arscoutViewer;
    viewer.resetView();
    viewer.renderNow();
    const rect = viewer.canvas.getBoundingClientRect();
    const hit = viewer.pickMesh(rect.left + rect.width / 2, rect.top + rect.height / 2);
    if (!hit) return null;
    const eye = viewer.camera.position.clone().sub(hit).normalize().add(hit);
    viewer.camera.position.copy(eye);
    viewer.controls.target.copy(hit);
    viewer.controls.update();
    return hit.toArray();
  });
  if (!near) fail('no mesh surface under the middle of the site view');
  const close = await settleMesh(page);
  const refined = Object.keys(close.shown).filter((t) => close.shown[t] < far.shown[t]);
  if (refined.length === 0) fail(`a metre from the surface no tile shows a finer level than from far: ${JSON.stringify(close.shown)}`);
  log(`streaming: first levels fetched ${JSON.stringify(firstLevels)}; from far ${JSON.stringify(far.shown)} ` +
    `(${far.triangles} triangles), a metre from the surface ${JSON.stringify(close.shown)} (${close.triangles} triangles)`);
  for (const [tile, level] of Object.entries(firstLevels)) {
    if (level !== far.coarsest[tile]) fail(`tile ${tile}'s first level fetched was ${level}, not its coarsest`);
  }
  return { far, close };
}

/**
 * A new version of the model with the same mesh: its levels are taken
 * over from the last version's, none fetched again.
 */
async function checkNewVersionKeepsLevels(page, site, requests) {
  if (!config.adminToken) {
    log('no ADMIN_TOKEN: the new version\'s mesh is not checked');
    return null;
  }
  const before = await page.evaluate(() => window.arscoutViewer.viewer.mesh.version);
  const fetched = requests.length;
  const response = await fetch(`${config.server}/v1/docs/sites/${encodeURIComponent(site)}/model`, {
    method: 'PATCH',
    headers: { Authorization: `Bearer ${config.adminToken}`, 'Content-Type': 'application/json' },
    body: JSON.stringify({ note: 'a new version with the same mesh' }),
  });
  if (!response.ok) fail(`PATCH the model: ${response.status} ${await response.text()}`);
  const version = Number((response.headers.get('etag') || '').replace(/"/g, ''));
  await page.waitForFunction((v) => window.arscoutViewer.viewer.mesh?.version === v, version,
    { timeout: 60000, polling: 200 });
  const shown = await settleMesh(page);
  const again = requests.slice(fetched).filter((url) => /\/mesh\/[^/]+\/[0-9]+/.test(url));
  log(`model v${before} -> v${version}: the mesh kept its levels, ${again.length} fetched again`);
  if (again.length > 0) fail(`the new version fetched levels it had: ${again.join(', ')}`);
  return { from: before, to: version, shown: shown.shown };
}

async function referenceView(page, capture) {
  // As the photo saw it: the view-from pose, no shading, no frusta.
  await page.uncheck('#edl');
  await page.uncheck('#show-frusta');
  await page.locator(`tr.capture-status[data-capture=${JSON.stringify(capture)}] button[data-action="view-from"]`).click();
  await choose(page, '#display-points');
  await settleView(page);
  const points = await readView(page, capture, config.cellPx, true);
  await choose(page, '#display-mesh');
  const mesh = await settleMesh(page);
  const { view } = await readView(page, capture, config.cellPx, false);
  if (config.screenshot) await page.screenshot({ path: config.screenshot });
  const figures = {
    capture,
    triangles: mesh.triangles,
    levels: mesh.shown,
    covered: view.covered,
    points_covered: points.view.covered,
    vs_points: zncc(view.cells, points.view.cells),
    vs_photo: zncc(view.cells, points.photo.cells),
    vs_mirrored: zncc(view.cells, points.mirrored.cells),
    points_vs_photo: zncc(points.view.cells, points.photo.cells),
  };
  // Both: the points over the mesh.
  await choose(page, '#display-both');
  await settleView(page);
  await settleMesh(page);
  figures.both = await page.evaluate(() => {
    const { viewer } = window.arscoutViewer;
    return { points: viewer.pointCount, triangles: viewer.triangleCount };
  });
  if (!(figures.both.points > 0 && figures.both.triangles > 0)) fail(`"both" draws ${JSON.stringify(figures.both)}`);
  return figures;
}

async function run(page, requests) {
  const site = await signIn(page);
  if (await page.isHidden('#display-mode')) fail('the points / mesh / both switch is hidden: does the model have no mesh?');
  const capture = await referenceCapture(page);
  await choose(page, '#display-mesh');
  await settleMesh(page);
  const firstLevels = {};
  for (const url of requests) {
    const m = /\/mesh\/([^/]+)\/([0-9]+)/.exec(url);
    if (m && !(m[1] in firstLevels)) firstLevels[m[1]] = Number(m[2]);
  }
  const streaming = await checkStreaming(page, firstLevels);
  const newVersion = await checkNewVersionKeepsLevels(page, site, requests);
  const figures = await referenceView(page, capture);
  figures.far = streaming.far;
  figures.close = streaming.close;
  figures.new_version = newVersion;
  console.log(`figures: ${JSON.stringify(figures)}`);
  const failures = [];
  if (!(figures.covered >= config.minCovered)) failures.push(`the mesh covers ${figures.covered.toFixed(3)} of the photo's view (at least ${config.minCovered})`);
  if (!(figures.vs_points.zncc >= config.minZnccPoints)) failures.push(`ZNCC with the points ${figures.vs_points.zncc.toFixed(3)} (at least ${config.minZnccPoints})`);
  if (!(figures.vs_photo.zncc >= config.minZnccPhoto)) failures.push(`ZNCC with the photo ${figures.vs_photo.zncc.toFixed(3)} (at least ${config.minZnccPhoto})`);
  if (!(figures.vs_mirrored.zncc <= config.maxZnccMirrored)) failures.push(`ZNCC with the mirrored photo ${figures.vs_mirrored.zncc.toFixed(3)} (at most ${config.maxZnccMirrored})`);
  if (failures.length) fail(failures.join('; '));
  console.log(`PASS mesh mode from ${capture}: covers ${(100 * figures.covered).toFixed(1)} % of the view, ` +
    `ZNCC ${figures.vs_points.zncc.toFixed(3)} with the points, ${figures.vs_photo.zncc.toFixed(3)} with the photo ` +
    `(mirrored ${figures.vs_mirrored.zncc.toFixed(3)}); coarsest levels first, finer close up`);
}

async function main() {
  const browser = await chromium.launch({ executablePath: config.chromium, headless: true, args: SOFTWARE_WEBGL_ARGS });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.on('pageerror', (err) => console.log(`  [browser exception] ${err.message}`));
  page.on('console', (message) => {
    if (message.type() === 'error' || message.type() === 'warning') console.log(`  [browser ${message.type()}] ${message.text()}`);
  });
  const requests = [];
  page.on('request', (request) => {
    if (request.url().includes('/mesh/')) requests.push(request.url());
  });
  let code = 0;
  try {
    await run(page, requests);
  } catch (err) {
    code = 1;
    console.log(`FAIL: ${err instanceof TestFailure ? err.message : err.stack || err}`);
  } finally {
    await browser.close();
  }
  process.exit(code);
}

main();
