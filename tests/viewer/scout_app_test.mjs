#!/usr/bin/env node
// End-to-end test of the scout app (viewer/web/scout) in headless Chromium
// with a phone's viewport and touch, against `arscout serve --with-engine`:
//
// - alice takes fountain-P11's 11 photos through a fake rear camera (a
//   canvas stream in place of getUserMedia showing each photo at full
//   size) with the geolocation set to each photo's gps.csv fix; the
//   network is cut for shots 4-7 and the page reloaded while offline (the
//   service worker serves the app, IndexedDB keeps the queue);
// - back online, every photo is stored exactly once (11 capture documents
//   created, once each), at least 9 are registered with the app's
//   estimated camera, the status bar shows the fix and its accuracy;
// - a registered photo shows the model drawn over it; withdrawing it from
//   the app removes it from the next model version;
// - bob, on a second page with his own token, takes a photo with location
//   denied (the status bar says why, whole; the photo waits on the phone),
//   then grants it (the photo goes with the fix and is registered): each page's
//   site map shows both scouts' cameras;
// - a photo the server refuses (422) is shown refused with the server's
//   message and leaves the queue; a revoked token stops the queue with a
//   clear message and keeps the photo on the phone.
//
// Settings (environment): SERVER, ALICE_TOKEN, BOB_TOKEN, ADMIN_TOKEN,
// SCENE (fountain-P11 folder), CHROMIUM, SCREENSHOTS (a folder: the capture
// and see-through screens as PNG), TIMEOUT_S (engine waits, default 420).

import crypto from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import { requireFromViewer, log, TestFailure, fail } from './harness.mjs';
import { phoneContext } from './scout_phone.mjs';

const { chromium } = requireFromViewer('playwright-core');
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const env = process.env;
for (const key of ['SERVER', 'ALICE_TOKEN', 'BOB_TOKEN', 'ADMIN_TOKEN', 'SCENE']) {
  if (!env[key]) {
    console.error(`scout_app_test: ${key} is not set`);
    process.exit(2);
  }
}
const server = env.SERVER.replace(/\/+$/, '');
const timeoutMs = 1000 * Number(env.TIMEOUT_S || 420);

/** gps.csv rows by image name. */
function readFixes(scene) {
  const lines = fs.readFileSync(path.join(scene, 'gps.csv'), 'utf8').trim().split('\n').slice(1);
  const fixes = new Map();
  for (const line of lines) {
    const [name, lat, lon, alt, hAcc, vAcc] = line.split(',');
    fixes.set(name, { lat: +lat, lon: +lon, alt: +alt, hAcc: +hAcc, vAcc: +vAcc });
  }
  return fixes;
}

async function api(token, url, init = {}) {
  const response = await fetch(server + url, {
    ...init,
    headers: { Authorization: `Bearer ${token}`, ...(init.headers || {}) },
  });
  if (!response.ok) fail(`${init.method || 'GET'} ${url}: HTTP ${response.status} ${await response.text()}`);
  return response.json();
}

async function until(what, probe, ms = timeoutMs, every = 1000) {
  const end = Date.now() + ms;
  for (;;) {
    const value = await probe();
    if (value) return value;
    if (Date.now() > end) fail(`timed out waiting for ${what}`);
    await sleep(every);
  }
}

async function openScout(browser, token, name) {
  const context = await phoneContext(browser);
  const page = await context.newPage();
  page.on('console', (m) => {
    if (m.type() === 'error') console.log(`  [${name} console] ${m.text()}`);
  });
  page.on('pageerror', (e) => console.log(`  [${name} page error] ${e.message}`));
  await page.goto(`${server}/scout/#token=${encodeURIComponent(token)}`);
  await page.waitForSelector('body[data-ready="true"]');
  if (page.url().includes('token=')) fail('the token stayed in the address');
  // The service worker must hold the app before the network is cut.
  await page.evaluate(async () => {
    await navigator.serviceWorker.ready;
  });
  await page.waitForFunction(() => navigator.serviceWorker.controller !== null);
  return { context, page, name };
}

/**
 * A wrong token at sign-in (issue 38): the dialog says exactly what is
 * wrong, the token is not kept, and nothing is sent.
 */
async function checkSignInRefusesAnUnknownToken(browser) {
  const context = await phoneContext(browser);
  const page = await context.newPage();
  const sent = [];
  page.on('request', (r) => {
    if (new URL(r.url()).pathname.startsWith('/v1/captures')) sent.push(`${r.method()} ${r.url()}`);
  });
  await page.goto(`${server}/scout/`);
  await page.waitForSelector('body[data-ready="true"]');
  await page.waitForSelector('#sign-in[open]');
  await page.fill('#token-input', `ars_${'0'.repeat(64)}`);
  await page.tap('#sign-in-ok');
  await page.waitForSelector('#sign-in[open] #sign-in-problem:not([hidden])', { timeout: 10000 });
  const problem = await page.textContent('#sign-in-problem');
  if (!/^unknown token/.test(problem)) fail(`an unknown token at sign-in says "${problem}"`);
  const kept = await page.evaluate(() => localStorage.getItem('arscout.scout.token'));
  if (kept) fail('a token the server refused was kept');
  await sleep(1000);
  if (sent.length) fail(`a refused sign-in sent ${sent.join(', ')}`);
  await context.close();
  log('sign-in: an unknown token is named, not kept, and nothing is sent');
}

/**
 * Shows a photo on the fake camera, sets the fix (none: the GPS stays as
 * it is), waits for frames, shoots.
 */
async function shoot(scout, imagePath, fix) {
  const { page } = scout;
  if ((await page.getAttribute('body', 'data-view')) !== 'capture') {
    await page.tap('#tabs button[data-view="capture"]');
  }
  const base64 = fs.readFileSync(imagePath).toString('base64');
  await page.evaluate((b) => window.__fake.showPhoto(b), base64);
  if (fix) await page.evaluate((f) => window.__fake.setFix(f), fix);
  const frames = await page.evaluate(() => window.__fake.frames);
  await page.waitForFunction((n) => window.__fake.frames >= n + 5, frames);
  await page.waitForFunction(() => document.getElementById('live').videoWidth === 3072);
  const before = await page.locator('#photos li').count();
  await page.tap('#shutter');
  await page.waitForFunction((n) => document.querySelectorAll('#photos li').length > n, before);
}

const queueCounts = (page) =>
  page.evaluate(() => ({ ...document.getElementById('queue-counts').dataset }));

// ---- the steps ----------------------------------------------------------------

/**
 * Every photo taken is on the phone (waiting, sending or sent), none lost,
 * and the `offlineShots` taken without a network are all still unsent.
 */
async function checkQueueHolds(page, shots, offlineShots, when) {
  const c = await queueCounts(page);
  const held = Number(c.waiting) + Number(c.sending) + Number(c.sent);
  const unsent = Number(c.waiting) + Number(c.sending);
  if (held !== shots || unsent < offlineShots) {
    fail(`${when}: the queue holds ${JSON.stringify(c)}; expected ${shots} photos, at least ${offlineShots} unsent`);
  }
}

async function captureWalk(alice, scene, fixes) {
  const names = [...fixes.keys()].sort();
  for (let i = 0; i < names.length; i++) {
    const shot = i + 1;
    if (shot === 4) {
      log('network cut (shots 4-7)');
      await alice.context.setOffline(true);
    }
    await shoot(alice, path.join(scene, 'images', names[i]), fixes.get(names[i]));
    log(`shot ${shot}: ${names[i]}`);
    if (shot === 5) {
      log('reload while offline');
      await alice.page.reload();
      await alice.page.waitForSelector('body[data-ready="true"]');
      await checkQueueHolds(alice.page, shot, 2, 'after the offline reload');
    }
    if (shot === 7) {
      await checkQueueHolds(alice.page, shot, 4, 'offline');
      const connection = await alice.page.textContent('#connection');
      if (connection !== 'offline') fail(`the status bar says "${connection}" while offline`);
      log('offline: shots 4-7 wait on the phone; network back');
      await alice.context.setOffline(false);
      // The link follows the real connection at once (issue 38), not the
      // feed's back-off (up to 30 s) or the offline event's leftover state.
      const back = Date.now();
      await alice.page
        .waitForSelector('#connection[data-state="live"]', { timeout: 2000 })
        .catch(() => fail('the link did not show "live" within 2 s of the network coming back'));
      log(`link live ${Date.now() - back} ms after the network came back`);
    }
  }
  await alice.page.waitForFunction(() => document.getElementById('queue-counts').dataset.sent === '11', null,
    { timeout: 120000 });
  log('all 11 sent');
}

/** Installable: the manifest names its icons and both are served. */
async function checkInstallable(scout) {
  const manifest = await scout.page.evaluate(async () => {
    const href = document.querySelector('link[rel="manifest"]').href;
    const m = await (await fetch(href)).json();
    const icons = await Promise.all(m.icons.map(async (i) => (await fetch(new URL(i.src, href))).status));
    return { display: m.display, start: m.start_url, icons, sizes: m.icons.map((i) => i.sizes) };
  });
  if (manifest.display !== 'standalone' || !manifest.sizes.includes('512x512') ||
      manifest.icons.some((status) => status !== 200)) {
    fail(`manifest ${JSON.stringify(manifest)}`);
  }
}

/** Touch targets of at least 48 px, portrait and landscape alike. */
async function checkLayout(scout) {
  const { page } = scout;
  for (const [width, height] of [[390, 844], [844, 390]]) {
    await page.setViewportSize({ width, height });
    await page.tap('#tabs button[data-view="capture"]');
    for (const selector of ['#shutter', '#blend', '#tabs button[data-view="photos"]', '#status-bar']) {
      const box = await page.locator(selector).boundingBox();
      const inside = box && box.x >= 0 && box.y >= 0 && box.x + box.width <= width + 1 && box.y + box.height <= height + 1;
      if (!inside) fail(`${selector} not on a ${width}x${height} screen: ${JSON.stringify(box)}`);
      if (selector !== '#status-bar' && (box.width < 48 || box.height < 48)) {
        fail(`${selector} is ${box.width}x${box.height} px on a ${width}x${height} screen`);
      }
    }
    const video = await page.locator('#live').boundingBox();
    if (!video || video.height < height / 3) fail(`the live view is ${JSON.stringify(video)} on ${width}x${height}`);
  }
  await page.setViewportSize({ width: 390, height: 844 });
  log('installable; portrait and landscape layouts hold their touch targets');
}

async function checkStoredOnce(adminToken) {
  const docs = await api(adminToken, '/v1/docs/captures?depth=1');
  const captures = docs.documents.filter((d) => /^\/captures\/[^/]+$/.test(d.path));
  const changes = await api(adminToken, '/v1/changes?since=0&pattern=/captures/*&limit=10000');
  const created = changes.changes.filter((c) => c.version === 1);
  const alices = captures.filter((d) => d.attrs.scout === 'alice');
  if (alices.length !== 11) fail(`${alices.length} capture documents for alice, expected 11`);
  const astray = alices.filter((d) => !d.path.startsWith('/captures/alice.'));
  if (astray.length) fail(`alice's captures outside her id space: ${astray.map((d) => d.path).join(' ')}`);
  const ids = new Set(created.map((c) => c.path));
  if (created.length !== captures.length || ids.size !== created.length) {
    fail(`${created.length} creations for ${captures.length} capture documents`);
  }
  log(`stored once: 11 capture documents, ${created.length} creations`);
  return alices;
}

async function checkRegistered(alice, adminToken) {
  await until('9 registered photos in the app', async () =>
    (await alice.page.locator('#photos li[data-status="registered"]').count()) >= 9);
  const site = await alice.page.textContent('#site-name');
  const model = await api(adminToken, `/v1/docs/sites/${encodeURIComponent(site)}/model`);
  const cameras = model.attrs.cameras.filter((c) => c.source === 'estimated' && /-3072x2048$/.test(c.id));
  const registered = model.attrs.images.filter((im) => cameras.some((c) => c.id === im.camera));
  if (registered.length < 9) fail(`${registered.length} images on the app's estimated camera, expected >= 9`);
  const version = Number(await alice.page.getAttribute('#model-version', 'data-version'));
  if (!version) fail('the status bar shows no model version');
  log(`registered ${registered.length} with camera ${cameras[0].id} (estimated), model v${model.version}`);
  return { site, model };
}

async function checkStatusBar(alice, fix) {
  const text = await alice.page.textContent('#gps-fix');
  if (!text.includes(fix.lat.toFixed(6)) || !text.includes(fix.lon.toFixed(6))) fail(`status bar fix "${text}"`);
  const accuracy = await alice.page.textContent('#gps-accuracy');
  if (!accuracy.includes(`±${fix.hAcc.toFixed(1)} m`)) fail(`status bar accuracy "${accuracy}"`);
  log(`status bar: ${text} ${accuracy}`);
}

/**
 * The see-through's switch to the textured surface (the server's engine runs
 * with --mesh): until the site has a surface the app says so and shows the
 * points; then the overlay is the surface's picture (whose pixels the C++
 * FountainSite tests compare with the photo), from the mesh the API lists.
 */
async function checkSurfaceOverlay(page, id, adminToken, site, screenshots) {
  await until('the see-through drawing the surface', async () => {
    await page.tap('#overlay-draw button[data-draw="mesh"]');
    try {
      await page.waitForFunction((c) => {
        const img = document.getElementById('see-through-overlay');
        return img.dataset.capture === c && img.dataset.draw === 'mesh' && !img.hidden &&
          img.complete && img.naturalWidth > 0;
      }, id, { timeout: 5000 });
      return true;
    } catch {
      const caption = await page.textContent('#see-through-caption');
      if (!caption.includes('no surface yet')) fail(`no surface and the caption says "${caption}"`);
      return false;
    }
  }, 120000, 2000);
  const pressed = await page.getAttribute('#overlay-draw button[data-draw="mesh"]', 'aria-pressed');
  if (pressed !== 'true') fail('the surface button is not shown pressed');
  const caption = await page.textContent('#see-through-caption');
  if (caption.includes('no surface yet')) fail(`the surface is shown and the caption says "${caption}"`);
  const mesh = await api(adminToken, `/v1/sites/${encodeURIComponent(site)}/mesh`);
  if (!(mesh.triangles > 0)) fail(`the site's mesh listing has ${mesh.triangles} triangles`);
  const shape = await page.evaluate(() => {
    const img = document.getElementById('see-through-overlay');
    return img.naturalWidth / img.naturalHeight;
  });
  if (Math.abs(shape - 1.5) > 0.01) fail(`the surface overlay is ${shape.toFixed(3)} wide for 1 high, not the photo's 1.5`);
  if (screenshots) await page.screenshot({ path: path.join(screenshots, 'scout-see-through-mesh.png') });
  log(`surface overlay shown for ${id} (the site's mesh: ${mesh.tiles.length} tiles, ${mesh.triangles} triangles)`);
  await page.tap('#overlay-draw button[data-draw="points"]');
}

async function checkOverlayAndWithdraw(alice, adminToken, site, screenshots) {
  const page = alice.page;
  // Live see-through: the latest registered photo's overlay over the camera.
  await page.waitForSelector('#live-overlay[data-capture]', { state: 'attached', timeout: 60000 });
  await page.tap('#blend');
  await page.waitForFunction(() => {
    const img = document.getElementById('live-overlay');
    return !img.hidden && img.complete && img.naturalWidth > 0;
  });
  log(`live view blends the overlay of ${await page.getAttribute('#live-overlay', 'data-capture')}`);
  if (screenshots) await page.screenshot({ path: path.join(screenshots, 'scout-capture.png') });
  await page.tap('#tabs button[data-view="photos"]');
  const row = page.locator('#photos li[data-status="registered"]').first();
  const id = await row.getAttribute('data-capture');
  const storedId = await row.getAttribute('data-server-id');
  if (storedId !== `alice.${id}`) fail(`photo ${id} is stored as ${storedId}, not under alice's name`);
  await row.tap();
  await page.waitForFunction((c) => {
    const img = document.getElementById('see-through-overlay');
    return img.dataset.capture === c && !img.hidden && img.complete && img.naturalWidth > 0;
  }, id, { timeout: 60000 });
  if (screenshots) await page.screenshot({ path: path.join(screenshots, 'scout-see-through.png') });
  log(`overlay shown for ${id}`);
  await checkSurfaceOverlay(page, id, adminToken, site, screenshots);
  const before = (await api(adminToken, `/v1/docs/sites/${encodeURIComponent(site)}/model`)).version;
  await page.tap('#withdraw');
  await page.waitForSelector(`#photos li[data-capture="${id}"][data-state="withdrawn"]`);
  const model = await until('a model version without the withdrawn photo', async () => {
    const m = await api(adminToken, `/v1/docs/sites/${encodeURIComponent(site)}/model`);
    return m.version > before && !m.attrs.images.some((im) => im.id === storedId) ? m : null;
  });
  log(`withdrawn ${id}: model v${model.version} has ${model.attrs.images.length} images without it`);
}

/**
 * Location denied, then granted (issue 38): the status bar says why there
 * is no fix and what to do, whole; the photo taken meanwhile waits on the
 * phone (nothing sent) and goes with the first fix once it comes.
 */
async function shootWithoutAFix(bob, imagePath, fix, adminToken) {
  const { page } = bob;
  await page.evaluate(() => window.__fake.denyLocation());
  await page.waitForSelector('#gps-status[data-state="none"]');
  const problem = await page.textContent('#gps-fix');
  if (!/^location denied: allow it/.test(problem)) fail(`with location denied the status bar says "${problem}"`);
  const clipped = await page.evaluate(() => {
    const el = document.getElementById('gps-fix');
    return el.scrollWidth > el.clientWidth + 1 || el.getBoundingClientRect().right > window.innerWidth;
  });
  if (clipped) fail(`the status bar clips "${problem}"`);
  const sent = [];
  const watch = (r) => {
    if (r.method() === 'POST' && new URL(r.url()).pathname === '/v1/captures') sent.push(r.url());
  };
  page.on('request', watch);
  await shoot(bob, imagePath, null);
  await page.waitForSelector('#queue-counts[data-no-fix="1"]');
  await sleep(2000);
  if (sent.length) fail('a photo taken without a fix was sent before the fix came');
  log(`location denied: "${problem}"; the photo waits on the phone`);
  await page.evaluate((f) => window.__fake.setFix(f), fix);
  await page.waitForSelector('#queue-counts[data-no-fix="0"]');
  page.off('request', watch);
  await until('bob\'s photo stored with the fix', async () => {
    const docs = await api(adminToken, '/v1/docs/captures?depth=1');
    const bobs = docs.documents.filter((d) => d.attrs.scout === 'bob');
    return bobs.length === 1 && bobs[0].attrs.gps && Math.abs(bobs[0].attrs.gps.lat - fix.lat) < 1e-9;
  }, 60000);
  log('location granted: the photo went with the first fix');
}

async function checkTwoScouts(alice, bob, scene, fixes, adminToken) {
  await shootWithoutAFix(bob, path.join(scene, 'images', '0010.jpg'), fixes.get('0010.jpg'), adminToken);
  await until('bob\'s photo registered', async () =>
    (await bob.page.locator('#photos li[data-status="registered"]').count()) >= 1);
  for (const scout of [alice, bob]) {
    await scout.page.tap('#tabs button[data-view="map"]');
    await until(`${scout.name}'s map showing both scouts`, async () =>
      (await scout.page.getAttribute('#site-map', 'data-scouts')) === 'alice,bob', 120000);
  }
  if (env.SCREENSHOTS) await alice.page.screenshot({ path: path.join(env.SCREENSHOTS, 'scout-map.png') });
  log('both maps show alice\'s and bob\'s cameras');
}

async function checkRefusalAndRevocation(bob, scene, fixes, adminToken) {
  const page = bob.page;
  await shoot(bob, path.join(scene, 'images', '0009.jpg'), { ...fixes.get('0009.jpg'), lat: 95 });
  const refused = page.locator('#photos li[data-state="refused"]');
  await until('the refused photo', async () => (await refused.count()) === 1, 60000);
  const label = await refused.first().locator('.photo-state').textContent();
  if (!/refused by the server: .*lat/.test(label)) fail(`refused photo says "${label}"`);
  log(`refused: ${label}`);
  const hash = crypto.createHash('sha256').update(env.BOB_TOKEN).digest('hex');
  await api(adminToken, `/v1/docs/auth/tokens/${hash}`, { method: 'DELETE' });
  await shoot(bob, path.join(scene, 'images', '0008.jpg'), fixes.get('0008.jpg'));
  await page.waitForSelector('#notice:not([hidden])', { timeout: 60000 });
  const notice = (await page.textContent('#notice-text')).trim();
  if (!notice.includes('no longer accepts this token')) fail(`revocation notice "${notice}"`);
  const counts = await queueCounts(page);
  if (counts.waiting !== '1') fail(`after revocation the queue holds ${JSON.stringify(counts)}`);
  log(`revoked: "${notice}", the photo kept`);
}

async function main() {
  const scene = env.SCENE;
  const fixes = readFixes(scene);
  const browser = await chromium.launch({
    executablePath: env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: ['--no-sandbox'],
  });
  let alice;
  let bob;
  try {
    await checkSignInRefusesAnUnknownToken(browser);
    alice = await openScout(browser, env.ALICE_TOKEN, 'alice');
    await checkInstallable(alice);
    await checkLayout(alice);
    await captureWalk(alice, scene, fixes);
    await checkStoredOnce(env.ADMIN_TOKEN);
    const { site } = await checkRegistered(alice, env.ADMIN_TOKEN);
    await checkStatusBar(alice, fixes.get('0010.jpg'));
    await checkOverlayAndWithdraw(alice, env.ADMIN_TOKEN, site, env.SCREENSHOTS);
    bob = await openScout(browser, env.BOB_TOKEN, 'bob');
    await checkTwoScouts(alice, bob, scene, fixes, env.ADMIN_TOKEN);
    await checkRefusalAndRevocation(bob, scene, fixes, env.ADMIN_TOKEN);
    log('PASS');
  } catch (err) {
    for (const s of [alice, bob]) {
      if (s && env.SCREENSHOTS) await s.page.screenshot({ path: path.join(env.SCREENSHOTS, `${s.name}-failure.png`) }).catch(() => {});
    }
    throw err;
  } finally {
    await browser.close();
  }
}

main().catch((err) => {
  console.error(err instanceof TestFailure ? `FAIL: ${err.message}` : err);
  process.exit(1);
});
