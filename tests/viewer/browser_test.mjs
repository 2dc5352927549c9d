#!/usr/bin/env node
// End-to-end test of the web viewer (viewer/web) in headless Chromium:
// sign in, check the site list, open the site, check the point cloud is on
// screen, upload one more photo through the API and wait for the page to
// show the new model version live, without a page reload.
//
// Settings come from the environment, or from KEY=VALUE arguments:
//   SERVER             base URL of `arscout serve --web-root ...` (required)
//   PLANNER_TOKEN      token typed into the viewer's sign-in form (required)
//   SCOUT_TOKEN        token for the upload (required)
//   UPLOAD_IMAGE       JPEG to upload (required)
//   UPLOAD_META        X-Capture-Metadata JSON for it (required)
//   EXPECT_CAPTURES    captures the site list must show before the upload
//   EXPECT_REGISTERED  registered captures it must show before the upload
//   SITE_ID            the site to open (default: the only one listed)
//   SCREENSHOT         PNG path (default viewer.png); a failure writes
//                      NAME-failure.png next to it
//   TIMEOUT_S          seconds allowed for the live update (default 240)
//   CHROMIUM           browser binary (default /usr/bin/chromium)
//   MIN_VARIANCE       least pixel variance of the 3D view (default 50)
//
// Uses playwright-core from viewer/web/node_modules (npm install there).

import fs from 'node:fs';
import path from 'node:path';
import {
  requireFromViewer, log, TestFailure, fail, keyValueSettings, SOFTWARE_WEBGL_ARGS,
} from './harness.mjs';

const { chromium } = requireFromViewer('playwright-core');

function settings() {
  const values = keyValueSettings();
  const required = ['SERVER', 'PLANNER_TOKEN', 'SCOUT_TOKEN', 'UPLOAD_IMAGE', 'UPLOAD_META'];
  const missing = required.filter((key) => !values[key]);
  if (missing.length) {
    console.error(`browser_test: missing settings: ${missing.join(', ')} (environment or KEY=VALUE arguments)`);
    process.exit(2);
  }
  const integer = (key) => {
    if (values[key] === undefined || values[key] === '') return null;
    const n = Number(values[key]);
    if (!Number.isInteger(n)) {
      console.error(`browser_test: ${key} must be an integer, not "${values[key]}"`);
      process.exit(2);
    }
    return n;
  };
  if (!fs.existsSync(values.UPLOAD_IMAGE)) {
    console.error(`browser_test: UPLOAD_IMAGE ${values.UPLOAD_IMAGE} does not exist`);
    process.exit(2);
  }
  let meta;
  try {
    meta = JSON.parse(values.UPLOAD_META);
  } catch (err) {
    console.error(`browser_test: UPLOAD_META is not JSON: ${err.message}`);
    process.exit(2);
  }
  return {
    server: values.SERVER.replace(/\/+$/, ''),
    plannerToken: values.PLANNER_TOKEN,
    scoutToken: values.SCOUT_TOKEN,
    siteId: values.SITE_ID || '',
    expectCaptures: integer('EXPECT_CAPTURES'),
    expectRegistered: integer('EXPECT_REGISTERED'),
    uploadImage: values.UPLOAD_IMAGE,
    uploadMeta: values.UPLOAD_META,
    captureId: meta.capture_id || '',
    screenshot: path.resolve(values.SCREENSHOT || 'viewer.png'),
    timeoutS: Number(values.TIMEOUT_S || 240),
    chromium: values.CHROMIUM || '/usr/bin/chromium',
    minVariance: Number(values.MIN_VARIANCE || 50),
  };
}

function failureScreenshotPath(screenshot) {
  const { dir, name } = path.parse(screenshot);
  return path.join(dir, `${name}-failure.png`);
}

/** CSS attribute selector for a row, quoting the value safely. */
function rowSelector(attribute, value) {
  return `tr[${attribute}=${JSON.stringify(value)}]`;
}

/** Reads the site row's numbers. */
async function siteRow(page, siteId) {
  return page.$eval(rowSelector('data-site', siteId), (row) => ({
    name: row.querySelector('.site-name')?.textContent.trim(),
    captures: Number(row.querySelector('.site-captures')?.textContent.trim()),
    registered: Number(row.querySelector('.site-registered')?.textContent.trim()),
    version: row.querySelector('.site-version')?.textContent.trim(),
  }));
}

/** Mean and variance of the 3D view's luminance, from the canvas itself. */
async function canvasStatistics(page) {
  return page.evaluate(() => {
    const source = document.querySelector('#canvas-host canvas');
    if (!source) return null;
    const width = 320;
    const height = Math.max(1, Math.round((width * source.height) / source.width));
    const scratch = document.createElement('canvas');
    scratch.width = width;
    scratch.height = height;
    const context = scratch.getContext('2d', { willReadFrequently: true });
    context.drawImage(source, 0, 0, width, height);
    const { data } = context.getImageData(0, 0, width, height);
    let sum = 0;
    let sumSq = 0;
    const n = width * height;
    for (let i = 0; i < data.length; i += 4) {
      const y = 0.299 * data[i] + 0.587 * data[i + 1] + 0.114 * data[i + 2];
      sum += y;
      sumSq += y * y;
    }
    const mean = sum / n;
    return { width: source.width, height: source.height, mean, variance: sumSq / n - mean * mean };
  });
}

async function run(config, page) {
  const timeoutMs = config.timeoutS * 1000;

  log(`opening ${config.server}/`);
  await page.goto(`${config.server}/`, { waitUntil: 'load' });
  await page.waitForSelector('#token-input', { state: 'visible', timeout: 30000 });
  await page.fill('#token-input', config.plannerToken);
  await page.click('#token-submit');
  // Either the list fills, or the token is refused and the form comes back.
  const signIn = await page.waitForFunction(() => {
    if (document.querySelector('tr[data-site]')) return 'ok';
    if (!document.getElementById('token-dialog').hidden) {
      return `refused: ${document.getElementById('token-message').textContent}`;
    }
    return false;
  }, null, { timeout: 60000, polling: 100 }).then((handle) => handle.jsonValue(), () => 'no site listed within 60 s');
  if (signIn !== 'ok') fail(`sign-in: ${signIn}`);
  log('signed in with the planner token');

  let siteId = config.siteId;
  if (!siteId) {
    const ids = await page.$$eval('tr[data-site]', (rows) => rows.map((r) => r.dataset.site));
    if (ids.length !== 1) fail(`SITE_ID not given and the list shows ${ids.length} sites: ${ids.join(', ')}`);
    siteId = ids[0];
  } else {
    await page.waitForSelector(rowSelector('data-site', siteId), { timeout: 30000 })
      .catch(() => fail(`site ${siteId} is not in the list`));
  }

  // The list may still be catching up with the store: allow it a few seconds.
  const matches = (row) =>
    (config.expectCaptures === null || row.captures === config.expectCaptures) &&
    (config.expectRegistered === null || row.registered === config.expectRegistered);
  let row = await siteRow(page, siteId);
  for (let i = 0; i < 20 && !matches(row); i++) {
    await page.waitForTimeout(500);
    row = await siteRow(page, siteId);
  }
  log(`site ${siteId} (${row.name}): ${row.captures} captures, ${row.registered} registered, model ${row.version}`);
  if (!matches(row)) {
    fail(`site list shows ${row.captures} captures / ${row.registered} registered, ` +
      `expected ${config.expectCaptures ?? 'any'} / ${config.expectRegistered ?? 'any'}`);
  }
  const capturesBefore = row.captures;

  await page.click(rowSelector('data-site', siteId));
  log('opened the site; waiting for the point cloud');
  await page.waitForSelector('body[data-cloud="loaded"]', { timeout: timeoutMs });
  const before = await page.evaluate(() => ({
    version: Number(document.getElementById('model-version').dataset.version),
    points: Number(document.getElementById('point-count').dataset.points),
    hash: location.hash,
  }));
  log(`cloud on screen: model v${before.version}, ${before.points} points (${before.hash})`);
  if (!(before.points > 0)) fail('the page shows no points');

  // Let the thumbnails arrive before the picture is taken.
  await page.waitForTimeout(1500);
  await page.screenshot({ path: config.screenshot });
  log(`screenshot: ${config.screenshot}`);
  const pixels = await canvasStatistics(page);
  if (!pixels) fail('no canvas in #canvas-host');
  log(`canvas ${pixels.width}x${pixels.height}: luminance mean ${pixels.mean.toFixed(1)}, variance ${pixels.variance.toFixed(1)}`);
  if (!(pixels.variance > config.minVariance)) {
    fail(`the 3D view looks blank: variance ${pixels.variance.toFixed(1)} <= ${config.minVariance}`);
  }

  await page.evaluate(() => {
    window.__arscoutMarker = 1;
  });
  const image = await fs.promises.readFile(config.uploadImage);
  log(`uploading ${config.uploadImage} (${image.length} B) as ${config.captureId || '(server-named)'}`);
  const response = await fetch(`${config.server}/v1/captures`, {
    method: 'POST',
    headers: {
      Authorization: `Bearer ${config.scoutToken}`,
      'Content-Type': 'image/jpeg',
      'X-Capture-Metadata': config.uploadMeta,
    },
    body: image,
  });
  const answer = await response.text();
  if (response.status !== 201) fail(`upload answered ${response.status}: ${answer.slice(0, 500)}`);
  let captureId = config.captureId;
  try {
    const doc = JSON.parse(answer);
    captureId = doc.path?.replace(/^\/captures\//, '') || captureId;
    log(`upload: 201 ${doc.path} status ${doc.attrs?.status} seq ${doc.seq}` +
      (response.headers.get('Idempotent-Replay') ? ' (idempotent replay!)' : ''));
  } catch {
    log('upload: 201 (body is not JSON)');
  }

  log(`waiting up to ${config.timeoutS} s for a model newer than v${before.version} and ${capturesBefore + 1} captures`);
  try {
    await page.waitForFunction(({ siteId: id, version, captures }) => {
      const shown = Number(document.getElementById('model-version')?.dataset.version);
      const row = document.querySelector(`tr[data-site=${JSON.stringify(id)}]`);
      const count = Number(row?.querySelector('.site-captures')?.textContent.trim());
      return shown > version && count === captures;
    }, { siteId, version: before.version, captures: capturesBefore + 1 }, { timeout: timeoutMs, polling: 250 });
  } catch {
    const now = await page.evaluate((id) => ({
      version: document.getElementById('model-version')?.dataset.version,
      captures: document.querySelector(`tr[data-site=${JSON.stringify(id)}] .site-captures`)?.textContent,
      live: document.getElementById('live-state')?.dataset.state,
    }), siteId);
    fail(`no live update within ${config.timeoutS} s: page shows model v${now.version}, ` +
      `${now.captures} captures, feed ${now.live}`);
  }
  const after = await page.evaluate((id) => ({
    version: Number(document.getElementById('model-version').dataset.version),
    points: Number(document.getElementById('point-count').dataset.points),
    marker: window.__arscoutMarker,
    captures: Number(document.querySelector(`tr[data-site=${JSON.stringify(id)}] .site-captures`).textContent),
    cloud: document.body.dataset.cloud,
  }), siteId);
  log(`live update: model v${after.version}, ${after.points} points, ${after.captures} captures`);
  if (after.marker !== 1) fail('the page was reloaded (window.__arscoutMarker is gone)');
  if (after.cloud !== 'loaded') fail('body[data-cloud] is no longer "loaded"');

  // The uploaded capture's row should show what the engine made of it.
  let captureStatus = '(not listed)';
  if (captureId) {
    const selector = `${rowSelector('data-capture', captureId)}[data-status="registered"], ` +
      `${rowSelector('data-capture', captureId)}[data-status="rejected"]`;
    await page.waitForSelector(selector, { timeout: 15000 }).catch(() => {});
    captureStatus = await page.$eval(rowSelector('data-capture', captureId),
      (r) => r.dataset.status + (r.querySelector('.capture-reason') ? ` (${r.querySelector('.capture-reason').textContent})` : ''))
      .catch(() => '(not listed)');
    log(`capture ${captureId} in the status panel: ${captureStatus}`);
  }

  await checkViewFromPhoto(page);
  await checkExportButtons(page, config);

  const finalShot = config.screenshot.replace(/\.png$/i, '') + '-after.png';
  await page.screenshot({ path: finalShot });
  log(`screenshot after the update: ${finalShot}`);

  console.log(`PASS site ${siteId}: model v${before.version} -> v${after.version}, ` +
    `points ${before.points} -> ${after.points}, captures ${capturesBefore} -> ${after.captures}, ` +
    `canvas variance ${pixels.variance.toFixed(1)}, capture ${captureId} ${captureStatus}, no page reload`);
}

/**
 * "View from this photo" (issue 38): the eye moves to a registered photo's
 * centre and looks where it looked; reset returns to the site's view.
 */
async function checkViewFromPhoto(page) {
  // Locators, not element handles: the list is drawn again on every
  // capture change, and a live update may come in between.
  const rows = page.locator('tr.capture-status[data-status="registered"]');
  if (!(await rows.count())) fail('no registered capture row to view from');
  const id = await rows.first().getAttribute('data-capture');
  await page.locator(`${rowSelector('data-capture', id)} button[data-action="view-from"]`).click();
  const seen = await page.evaluate((capture) => {
    const { viewer, state } = window.arscoutViewer;
    const image = state.model.attrs.images.find((im) => im.id === capture);
    const forward = viewer.camera.getWorldDirection(new viewer.camera.position.constructor());
    // The photo's optical axis: the third row of its world-to-camera R.
    const [w, x, y, z] = image.qvec;
    const axis = [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)];
    return {
      eye: viewer.camera.position.toArray(), centre: image.centre,
      dot: forward.x * axis[0] + forward.y * axis[1] + forward.z * axis[2],
    };
  }, id);
  const off = Math.hypot(...seen.eye.map((v, i) => v - seen.centre[i]));
  if (off > 1e-3 || seen.dot < 0.9999) {
    fail(`view from ${id}: the eye is ${off} from its centre, looking ${Math.acos(Math.min(1, seen.dot)) * 180 / Math.PI} degrees off`);
  }
  await page.click('#reset-view');
  const [back, home] = await page.evaluate(() => {
    const { viewer } = window.arscoutViewer;
    return [viewer.camera.position.toArray(), viewer.home.position.toArray()];
  });
  if (Math.hypot(...back.map((v, i) => v - home[i])) > 1e-6) fail('reset did not return to the site\'s view');
  log(`view from ${id}: the eye at its centre, looking along its axis; reset returns`);
}

/**
 * The export buttons are the server's registry (GET /v1/exports), one per
 * format, in its order (issue 39): a format added on the server needs no
 * change to the page.
 */
async function checkExportButtons(page, config) {
  const response = await fetch(`${config.server}/v1/exports`, {
    headers: { Authorization: `Bearer ${config.plannerToken}` },
  });
  if (!response.ok) fail(`GET /v1/exports: ${response.status}`);
  const listed = (await response.json()).formats.map((f) => f.name);
  const buttons = await page.$$eval('#exports button[data-format]', (all) => all.map((b) => b.dataset.format));
  if (listed.length < 7 || JSON.stringify(buttons) !== JSON.stringify(listed)) {
    fail(`export buttons ${buttons.join(', ')} against the registry's ${listed.join(', ')}`);
  }
  log(`export buttons: ${buttons.join(', ')} (GET /v1/exports)`);
}

async function main() {
  const config = settings();
  log(`launching ${config.chromium}`);
  const browser = await chromium.launch({
    executablePath: config.chromium,
    headless: true,
    args: SOFTWARE_WEBGL_ARGS,
  });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.on('console', (message) => {
    if (message.type() === 'error' || message.type() === 'warning') {
      console.log(`  [browser ${message.type()}] ${message.text()}`);
    }
  });
  page.on('pageerror', (err) => console.log(`  [browser exception] ${err.message}`));
  page.on('requestfailed', (request) => {
    const reason = request.failure()?.errorText || '';
    if (reason !== 'net::ERR_ABORTED') console.log(`  [browser request failed] ${request.url()} ${reason}`);
  });

  let code = 0;
  try {
    await run(config, page);
  } catch (err) {
    code = 1;
    console.log(`FAIL: ${err instanceof TestFailure ? err.message : err.stack || err}`);
    const shot = failureScreenshotPath(config.screenshot);
    await page.screenshot({ path: shot }).then(() => console.log(`failure screenshot: ${shot}`), () => {});
  } finally {
    await browser.close();
  }
  process.exit(code);
}

main();
