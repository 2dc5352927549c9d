#!/usr/bin/env node
// The fountain wall's height measured as a planner would, in headless
// Chromium, on the fountain-P11 site of the viewer_fountain fixture: open
// the site, take the height tool, click the ground at the foot of the brick
// wall and then the wall's top edge, each click snapped by the viewer to the
// drawn point nearest the cursor. Three tries, from three viewpoints 35
// degrees apart around the wall's normal; the three heights must agree
// within MAX_SPREAD_M, and each click must land within MAX_SNAP_M of where
// it was aimed (not on a stray point in front of the wall).
//
// Where to click comes from the cloud the page shows (confident points):
// the ground is the most common height below the wall, the wall the
// vertical plane through the points above it, and the column the wall's
// 25th percentile along its length (left of the fountain, which stands in
// the middle). The same three tries with low-confidence points shown are
// logged for comparison.
//
// Settings from the environment:
//   SERVER, PLANNER_TOKEN   the server and a planner token (required)
//   SITE_ID                 the site (default: the only one listed)
//   MAX_SPREAD_M (0.10), MAX_SNAP_M (0.35)
//   SCREENSHOT              PNG of the last measurement
//   CHROMIUM                browser binary (default /usr/bin/chromium)
// Prints one JSON line of figures ("figures: {...}") for bench/RESULTS.md.

import { requireFromViewer, log, TestFailure, fail, SOFTWARE_WEBGL_ARGS } from './harness.mjs';
import { settleView, lookAt, screenPosition } from './viewer_page.mjs';

const { chromium } = requireFromViewer('playwright-core');

const env = process.env;
const config = {
  server: (env.SERVER || '').replace(/\/+$/, ''),
  token: env.PLANNER_TOKEN || '',
  siteId: env.SITE_ID || '',
  maxSpread: Number(env.MAX_SPREAD_M || 0.1),
  maxSnap: Number(env.MAX_SNAP_M || 0.35),
  screenshot: env.SCREENSHOT || '',
  chromium: env.CHROMIUM || '/usr/bin/chromium',
};
if (!config.server || !config.token) {
  console.error('wall_height_browser_test: SERVER and PLANNER_TOKEN are required');
  process.exit(2);
}

// The viewpoints: around the wall's normal, horizontally, at this distance
// from the column and this height above the ground (a person's eye, a
// little raised, as one orbits to see the top).
const TRY_DEG = [-35, 0, 35];
const VIEW_DISTANCE_M = 9;
const VIEW_HEIGHT_M = 2.5;

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

/**
 * The points of the loaded nodes that are drawn (confident ones, by the
 * viewer's default), as [x, y, z] arrays, at most `limit` of them evenly.
 */
async function shownPoints(page, limit = 200000) {
  return page.evaluate((max) => {
    const { viewer } = window.arscoutViewer;
    const all = [];
    for (const node of viewer.lod.nodes) {
      const geometry = node.object?.geometry;
      if (!geometry) continue;
      const p = geometry.getAttribute('position').array;
      const s = geometry.getAttribute('support')?.array;
      for (let i = 0; i < p.length / 3; i++) {
        if (s && s[i] > 0 && s[i] < viewer.minSupport) continue;
        all.push([p[3 * i], p[3 * i + 1], p[3 * i + 2]]);
      }
    }
    const step = Math.max(1, Math.floor(all.length / max));
    return all.filter((_, i) => i % step === 0);
  }, limit);
}

const quantile = (values, q) => {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.max(0, Math.round(q * (sorted.length - 1))))];
};

/** The most common height among `zs`, in 10 cm bins. */
function modeHeight(zs) {
  const bins = new Map();
  for (const z of zs) {
    const b = Math.floor(z / 0.1);
    bins.set(b, (bins.get(b) || 0) + 1);
  }
  let best = null;
  for (const [b, n] of bins) if (!best || n > best[1]) best = [b, n];
  return (best[0] + 0.5) * 0.1;
}

/**
 * The wall: a vertical plane through the points above the ground (the
 * principal direction of their plan), refined twice on the points near
 * it; its normal faces the cameras.
 */
function wallPlane(points, ground, cameras) {
  let near = points.filter((p) => p[2] > ground + 1);
  let mean, along, normal;
  for (let round = 0; round < 3; round++) {
    mean = [0, 1].map((a) => near.reduce((s, p) => s + p[a], 0) / near.length);
    let sxx = 0, sxy = 0, syy = 0;
    for (const p of near) {
      const dx = p[0] - mean[0], dy = p[1] - mean[1];
      sxx += dx * dx, sxy += dx * dy, syy += dy * dy;
    }
    const angle = 0.5 * Math.atan2(2 * sxy, sxx - syy);
    along = [Math.cos(angle), Math.sin(angle)];
    normal = [-along[1], along[0]];
    near = near.filter((p) => Math.abs((p[0] - mean[0]) * normal[0] + (p[1] - mean[1]) * normal[1]) < 0.4);
  }
  const eye = [0, 1].map((a) => cameras.reduce((s, c) => s + c[a], 0) / cameras.length);
  if ((eye[0] - mean[0]) * normal[0] + (eye[1] - mean[1]) * normal[1] < 0) normal = normal.map((v) => -v);
  return { mean, along, normal, points: near };
}

/** The foot and the top of the wall at its 25th percentile along it. */
function clickTargets(points, cameras) {
  const cameraZ = cameras.reduce((s, c) => s + c[2], 0) / cameras.length;
  const ground = modeHeight(points.map((p) => p[2]).filter((z) => z < cameraZ - 0.8));
  const wall = wallPlane(points, ground, cameras);
  const t = (p) => (p[0] - wall.mean[0]) * wall.along[0] + (p[1] - wall.mean[1]) * wall.along[1];
  const column = quantile(wall.points.map(t), 0.25);
  const inColumn = wall.points.filter((p) => Math.abs(t(p) - column) < 0.15);
  if (inColumn.length < 50) fail(`only ${inColumn.length} wall points in the measured column`);
  const top = quantile(inColumn.map((p) => p[2]), 0.99);
  const base = [0, 1].map((a) => wall.mean[a] + column * wall.along[a]);
  return {
    ground,
    top,
    normal: wall.normal,
    base,
    foot: [base[0] + 0.3 * wall.normal[0], base[1] + 0.3 * wall.normal[1], ground],
    edge: [base[0], base[1], top - 0.05],
  };
}

async function cameraCentres(site) {
  const response = await fetch(`${config.server}/v1/docs/sites/${encodeURIComponent(site)}/model`, {
    headers: { Authorization: `Bearer ${config.token}` },
  });
  if (response.status !== 200) fail(`GET the model: ${response.status}`);
  const model = await response.json();
  const centres = [];
  for (const image of model.attrs?.images || []) {
    if (Array.isArray(image.centre)) centres.push(image.centre);
  }
  if (centres.length < 3) fail(`the model lists ${centres.length} camera centres`);
  return centres;
}

/** Looks at `target` from `eye`, settles, and clicks where it is drawn. */
async function clickFrom(page, eye, target) {
  await lookAt(page, eye, target);
  // Clicks on one spot in quick succession would make a double click.
  await page.waitForTimeout(600);
  const at = await screenPosition(page, target);
  if (!at) fail(`${target} is behind the camera`);
  await page.mouse.click(at.x, at.y);
}

/** One try of the height tool from `degrees` around the wall's normal. */
async function measureHeight(page, targets, degrees) {
  const a = (degrees * Math.PI) / 180;
  const n = targets.normal;
  const dir = [n[0] * Math.cos(a) - n[1] * Math.sin(a), n[0] * Math.sin(a) + n[1] * Math.cos(a)];
  const eye = [targets.base[0] + VIEW_DISTANCE_M * dir[0], targets.base[1] + VIEW_DISTANCE_M * dir[1],
    targets.ground + VIEW_HEIGHT_M];
  await page.click('#measure-tools button[data-tool="height"]');
  await clickFrom(page, eye, targets.foot);
  await clickFrom(page, eye, targets.edge);
  const result = JSON.parse(await page.getAttribute('#measure-result', 'data-result'));
  if (!result.done) fail(`the height measurement from ${degrees} degrees did not finish: ${JSON.stringify(result)}`);
  const off = result.points.map((p, i) => {
    const aimed = i === 0 ? targets.foot : targets.edge;
    return Math.hypot(p[0] - aimed[0], p[1] - aimed[1], p[2] - aimed[2]);
  });
  log(`from ${degrees} deg: height ${result.dz.toFixed(3)} m, clicks snapped ${off.map((o) => o.toFixed(2)).join(' and ')} m from their aim`);
  return { dz: result.dz, off };
}

async function tries(page, targets) {
  const results = [];
  for (const degrees of TRY_DEG) results.push(await measureHeight(page, targets, degrees));
  const heights = results.map((r) => r.dz);
  return { heights, spread: Math.max(...heights) - Math.min(...heights), off: results.flatMap((r) => r.off) };
}

async function run(page) {
  const site = await signIn(page);
  await settleView(page);
  const cameras = await cameraCentres(site);
  const points = await shownPoints(page);
  const targets = clickTargets(points, cameras);
  log(`ground at ${targets.ground.toFixed(2)} m, wall top ${targets.top.toFixed(2)} m at the column ` +
    `(${targets.base.map((v) => v.toFixed(2)).join(', ')}), from ${points.length} shown points`);

  const confident = await tries(page, targets);
  if (config.screenshot) await page.screenshot({ path: config.screenshot });
  await page.click('#hide-low-confidence');
  const everything = await tries(page, targets);
  await page.click('#hide-low-confidence');
  const figures = {
    aimed_height_m: targets.top - 0.05 - targets.ground,
    confident: confident.heights, confident_spread_m: confident.spread,
    all_points: everything.heights, all_points_spread_m: everything.spread,
  };
  console.log(`figures: ${JSON.stringify(figures)}`);
  if (!(confident.spread <= config.maxSpread)) {
    fail(`the three heights ${confident.heights.map((h) => h.toFixed(3)).join(', ')} spread ` +
      `${confident.spread.toFixed(3)} m (at most ${config.maxSpread})`);
  }
  const worst = Math.max(...confident.off);
  if (!(worst <= config.maxSnap)) fail(`a click snapped ${worst.toFixed(2)} m from its aim (at most ${config.maxSnap})`);
  console.log(`PASS wall height ${confident.heights.map((h) => h.toFixed(3)).join(', ')} m from three viewpoints ` +
    `(spread ${confident.spread.toFixed(3)} m; with low-confidence points ${everything.spread.toFixed(3)} m)`);
}

async function main() {
  const browser = await chromium.launch({ executablePath: config.chromium, headless: true, args: SOFTWARE_WEBGL_ARGS });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.on('pageerror', (err) => console.log(`  [browser exception] ${err.message}`));
  let code = 0;
  try {
    await run(page);
  } catch (err) {
    code = 1;
    console.log(`FAIL: ${err instanceof TestFailure ? err.message : err.stack || err}`);
  } finally {
    await browser.close();
  }
  process.exit(code);
}

main();
