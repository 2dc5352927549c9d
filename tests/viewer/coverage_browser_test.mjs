#!/usr/bin/env node
// The scout app's coverage guidance (issue 38) on a rendered block site
// with one facade nobody photographed (coverage_browser_test.sh made it):
//
// - the API (GET /v1/sites/{id}/coverage) marks that facade (an
//   unseen_facade line along it) and its first suggestion points at it:
//   standing within 10 m of the facade, looking within 45 degrees of its
//   middle;
// - the app on a phone (viewport, touch, fake camera and GPS), standing
//   where the scout's walk stopped before the facade, finds the site near
//   its fix before any photo of its own, draws the unseen side on its map
//   (dashed red pixels) with the suggestions, and its camera view's arrow
//   points at the first suggestion, which is also at that facade.
//
// Settings (environment): SERVER, TOKEN (a scout's), SITE_DIR (render-site
// --leave-unseen's folder), CHROMIUM, SCREENSHOTS (a folder for the
// coverage map and the next-shot arrow, as docs/scout-app.md shows them).

import fs from 'node:fs';
import path from 'node:path';
import { requireFromViewer, log, TestFailure, fail } from './harness.mjs';
import { phoneContext } from './scout_phone.mjs';

const { chromium } = requireFromViewer('playwright-core');

const env = process.env;
for (const key of ['SERVER', 'TOKEN', 'SITE_DIR']) {
  if (!env[key]) {
    console.error(`coverage_browser_test: ${key} is not set`);
    process.exit(2);
  }
}
const server = env.SERVER.replace(/\/+$/, '');
const MAX_DISTANCE_M = 10;
const MAX_ANGLE_DEG = 45;

async function api(url) {
  const response = await fetch(server + url, { headers: { Authorization: `Bearer ${env.TOKEN}` } });
  if (!response.ok) fail(`GET ${url}: HTTP ${response.status} ${await response.text()}`);
  return response.json();
}

// ---- geometry on a local tangent plane round the facade ----------------------

const unseen = JSON.parse(fs.readFileSync(path.join(env.SITE_DIR, 'unseen_facade.json'), 'utf8'));
const EARTH_RADIUS_M = 6378137;
const rad = Math.PI / 180;
function enu(lat, lon) {
  return {
    e: (lon - unseen.from.lon) * rad * EARTH_RADIUS_M * Math.cos(unseen.from.lat * rad),
    n: (lat - unseen.from.lat) * rad * EARTH_RADIUS_M,
  };
}
const wallFrom = enu(unseen.from.lat, unseen.from.lon);
const wallTo = enu(unseen.to.lat, unseen.to.lon);
const wallMiddle = { e: (wallFrom.e + wallTo.e) / 2, n: (wallFrom.n + wallTo.n) / 2 };

function distanceToWall(p) {
  const ex = wallTo.e - wallFrom.e, ey = wallTo.n - wallFrom.n;
  const t = Math.max(0, Math.min(1, ((p.e - wallFrom.e) * ex + (p.n - wallFrom.n) * ey) / (ex * ex + ey * ey)));
  return Math.hypot(p.e - wallFrom.e - t * ex, p.n - wallFrom.n - t * ey);
}
const bearing = (from, to) => (Math.atan2(to.e - from.e, to.n - from.n) / rad + 360) % 360;
const angleBetween = (a, b) => Math.abs(((a - b + 540) % 360) - 180);
const fromLonLat = ([lon, lat]) => enu(lat, lon);

/** Whether a suggestion stands within 10 m of the facade, facing it. */
function judge(feature) {
  const at = fromLonLat(feature.geometry.coordinates);
  const distance = distanceToWall(at);
  const angle = angleBetween(feature.properties.heading_deg, bearing(at, wallMiddle));
  return { distance, angle, ok: distance <= MAX_DISTANCE_M && angle <= MAX_ANGLE_DEG };
}

const suggestionsOf = (coverage) =>
  coverage.features.filter((f) => f.properties.feature === 'suggestion').sort((a, b) => a.properties.rank - b.properties.rank);

/** An unseen_facade line along the facade: middle within 3 m, within 30 degrees. */
function marksTheFacade(coverage) {
  return coverage.features.some((f) => {
    if (f.properties.feature !== 'unseen_facade') return false;
    const [a, b] = f.geometry.coordinates.map(fromLonLat);
    const middle = { e: (a.e + b.e) / 2, n: (a.n + b.n) / 2 };
    const along = angleBetween(bearing(a, b), bearing(wallFrom, wallTo)) % 180;
    return distanceToWall(middle) <= 3 && Math.min(along, 180 - along) <= 30;
  });
}

// ---- the walk: where the scout stopped before the facade ----------------------

/** gps.csv's fix (and photo) of the last photo before the stretch left out. */
function whereTheScoutStopped() {
  const rows = fs.readFileSync(path.join(env.SITE_DIR, 'gps.csv'), 'utf8').trim().split('\n').slice(1);
  const fixes = rows.map((line) => {
    const [name, lat, lon, alt, hAcc, vAcc] = line.split(',');
    return { name, index: parseInt(name, 10), lat: +lat, lon: +lon, alt: +alt, hAcc: +hAcc, vAcc: +vAcc };
  });
  const before = fixes.findIndex((f, i) => i + 1 < fixes.length && fixes[i + 1].index !== f.index + 1);
  return fixes[before >= 0 ? before : fixes.length - 1];
}

// ---- the checks ------------------------------------------------------------------

async function checkApi(site) {
  const coverage = await api(`/v1/sites/${encodeURIComponent(site)}/coverage`);
  if (!marksTheFacade(coverage)) fail('the coverage does not mark the facade nobody photographed');
  const [first] = suggestionsOf(coverage);
  if (!first) fail('no suggestion');
  const j = judge(first);
  log(`API: first suggestion "${first.properties.reason}" ${j.distance.toFixed(1)} m from the facade, ` +
    `${j.angle.toFixed(0)} degrees off its middle`);
  if (!j.ok) fail(`the first suggestion does not point at the facade (${MAX_DISTANCE_M} m, ${MAX_ANGLE_DEG} degrees)`);
}

async function openApp(browser, fix) {
  const context = await phoneContext(browser);
  const page = await context.newPage();
  page.on('pageerror', (e) => console.log(`  [page error] ${e.message}`));
  await page.goto(`${server}/scout/#token=${encodeURIComponent(env.TOKEN)}`);
  await page.waitForSelector('body[data-ready="true"]');
  await page.evaluate((f) => window.__fake.setFix(f), fix);
  return { context, page };
}

/** The map draws the unseen side: pixels of its dashed red line. */
async function redPixels(page) {
  return page.evaluate(() => {
    const canvas = document.getElementById('site-map');
    const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    let red = 0;
    for (let i = 0; i < data.length; i += 4) {
      if (data[i] > 230 && data[i + 1] > 40 && data[i + 1] < 80 && data[i + 2] > 30 && data[i + 2] < 70) red++;
    }
    return red;
  });
}

async function checkApp(browser, site, fix) {
  const { context, page } = await openApp(browser, fix);
  await page.waitForFunction((s) => document.getElementById('site-name').textContent === s, site, { timeout: 30000 })
    .catch(() => fail(`the app did not find site ${site} near its fix`));
  await page.waitForSelector('#site-map[data-suggestions]:not([data-suggestions="0"])', { state: 'attached', timeout: 30000 });
  await page.waitForSelector('#next-shot:not([hidden])');
  // What the app was given: the coverage ranked from where the scout stands.
  const near = await api(`/v1/sites/${encodeURIComponent(site)}/coverage?near=${fix.lat.toFixed(7)},${fix.lon.toFixed(7)}`);
  const [first] = suggestionsOf(near);
  const j = judge(first);
  if (!j.ok) fail(`from where the scout stopped, the first suggestion is ${j.distance.toFixed(1)} m and ${j.angle.toFixed(0)} degrees off the facade`);
  const arrow = await page.evaluate(() => ({ ...document.getElementById('next-shot').dataset }));
  const self = enu(fix.lat, fix.lon);
  const expected = bearing(self, fromLonLat(first.geometry.coordinates));
  if (angleBetween(Number(arrow.bearing), expected) > 2) fail(`the arrow points ${arrow.bearing}, the suggestion is at ${expected.toFixed(0)}`);
  const text = await page.textContent('#next-shot-text');
  if (!text.includes(first.properties.reason)) fail(`the arrow says "${text}"`);
  log(`app: arrow ${arrow.bearing} degrees, "${text}"`);
  if (env.SCREENSHOTS) {
    // The scout's last photo on the fake camera, as the live view.
    const photo = fs.readFileSync(path.join(env.SITE_DIR, 'images', fix.name)).toString('base64');
    await page.evaluate((b) => window.__fake.showPhoto(b), photo);
    await page.waitForTimeout(500);
    await page.screenshot({ path: path.join(env.SCREENSHOTS, 'scout-next-shot.jpg'), type: 'jpeg', quality: 80 });
  }

  await page.tap('#tabs button[data-view="map"]');
  await page.waitForFunction(() => document.getElementById('site-map').dataset.unseen !== '0');
  const red = await redPixels(page);
  if (red < 20) fail(`the map shows ${red} pixels of the unseen side's red line`);
  const legend = await page.locator('#scout-legend li').allTextContents();
  if (!legend.some((t) => t.startsWith('alice'))) fail(`the legend lists ${JSON.stringify(legend)}`);
  log(`app: map marks the unseen side (${red} red pixels), legend ${JSON.stringify(legend)}`);
  if (env.SCREENSHOTS) await page.screenshot({ path: path.join(env.SCREENSHOTS, 'scout-coverage-map.jpg'), type: 'jpeg', quality: 80 });
  await context.close();
}

async function main() {
  const sites = (await api('/v1/sites')).sites;
  if (sites.length !== 1) fail(`${sites.length} sites, expected 1`);
  const site = sites[0].path.split('/').pop();
  log(`site ${site}; the facade nobody photographed faces ${unseen.facing_deg.toFixed(0)} degrees ` +
    `(${unseen.photos_left_out} photos left out)`);
  await checkApi(site);
  const browser = await chromium.launch({ executablePath: env.CHROMIUM || '/usr/bin/chromium', args: ['--no-sandbox'] });
  try {
    await checkApp(browser, site, whereTheScoutStopped());
  } finally {
    await browser.close();
  }
  log('PASS');
}

main().catch((err) => {
  console.log(err instanceof TestFailure ? `FAIL: ${err.message}` : err.stack);
  process.exit(1);
});
