// The scout app (docs/scout-app.md): capture, status bar, the upload queue,
// feedback per photo, the see-through view and the site map, wired to the
// API (docs/api.md). Every photo is kept on the phone (store.js) before it
// is sent (uploader.js); the change feed (../live.js) brings the engine's
// verdicts.

import { ApiClient, healthz } from '../api.js';
import { CaptureStatus } from '../capture_status.js';
import { LiveFeed } from '../live.js';
import { parsePly } from '../ply.js';
import { debounce, serialized } from '../util.js';
import { Camera } from './camera.js';
import { describe } from './feedback.js';
import { MAX_FIX_AGE_S, Position } from './position.js';
import { checkToken } from './sign_in.js';
import { SiteMap, enuOf, scoutColours } from './site_map.js';
import { PhotoStore } from './store.js';
import { TOKEN_REJECTED, Uploader } from './uploader.js';

const TOKEN_KEY = 'arscout.scout.token';
// A phone's main camera: about 26 mm in 35 mm terms. The engine refines it
// (source "estimated"); a camera calibrated with `arscout calibrate` under
// the same id is used as it is.
const PRIOR_FOCAL_35MM = 26;

const $ = (id) => document.getElementById(id);

/** The token lives in localStorage: typed (or scanned) once per device. */
const tokens = {
  get: () => localStorage.getItem(TOKEN_KEY) || '',
  set: (t) => localStorage.setItem(TOKEN_KEY, t),
};

const state = {
  photos: new Map(), // captureId -> record
  site: '', // the site the scout's latest placed photo belongs to
  model: null, // that site's model document
  scout: '', // this token's scout name, learnt from the first upload
  device: '',
  objectUrls: new Map(), // captureId -> thumbnail URL
  shown: '', // the photo in the see-through view
  overlayDraw: 'points', // what the see-through draws: 'points' or 'mesh'
};

const api = new ApiClient({ tokens, onUnauthorized: () => tokenRejected(TOKEN_REJECTED) });
const camera = new Camera($('live'));
const position = new Position(() => renderStatus());
const siteMap = new SiteMap($('site-map'));
let store;
let uploader;

// ---- token -----------------------------------------------------------------

/** A token in the address (the pairing QR code's #token=...) is taken once. */
function tokenFromAddress() {
  const hash = new URLSearchParams(location.hash.slice(1));
  const token = hash.get('token');
  if (!token) return;
  tokens.set(token);
  history.replaceState(null, '', location.pathname + location.search);
}

function askForToken(problem = '') {
  const dialog = $('sign-in');
  $('sign-in-problem').textContent = problem;
  $('sign-in-problem').hidden = !problem;
  if (!dialog.open) dialog.showModal();
}

/**
 * The server refused the token: the queue stops and says so, but the
 * camera keeps working (photos wait on the phone) until the scout asks
 * for the sign-in form.
 */
function tokenRejected(message) {
  if (!tokens.get()) {
    askForToken();
    return;
  }
  showNotice(message, { signIn: true });
  if (uploader) uploader.halt(message);
}

/** Keeps a token only once the server has said who it is (or cannot say). */
async function onTokenEntered() {
  const token = $('token-input').value.trim();
  if (!token) return;
  $('token-input').value = '';
  const checked = await checkToken(token);
  if (!checked.me && !checked.keep) {
    askForToken(checked.problem);
    return;
  }
  tokens.set(token);
  if (checked.me) learnScout(checked.me.name);
  if (checked.problem) showNotice(checked.problem);
  else hideNotice();
  uploader.resume();
  follow();
}

/** A stored token is asked about again at start: it may have been revoked. */
async function recheckToken() {
  const checked = await checkToken(tokens.get());
  if (checked.me) learnScout(checked.me.name);
  else if (!checked.keep) tokenRejected(checked.problem);
}

function learnScout(name) {
  if (!name || state.scout === name) return;
  state.scout = name;
  store.setSetting('scout', name).catch(() => {});
}

// ---- status bar and notices -------------------------------------------------

function showNotice(text, { signIn = false } = {}) {
  $('notice-text').textContent = text;
  $('notice-sign-in').hidden = !signIn;
  $('notice').hidden = false;
}

function hideNotice() {
  $('notice').hidden = true;
}

function renderGps() {
  const cell = $('gps-status');
  const age = position.age();
  if (!position.fix) {
    cell.dataset.state = 'none';
    $('gps-fix').textContent = position.problem || 'no fix';
    $('gps-accuracy').textContent = '';
    return;
  }
  const { lat, lon, hAcc } = position.fix;
  cell.dataset.state = age > 30 ? 'stale' : hAcc <= 10 ? 'good' : 'poor';
  $('gps-fix').textContent = `${lat.toFixed(6)}, ${lon.toFixed(6)}`;
  $('gps-accuracy').textContent = `±${hAcc < 10 ? hAcc.toFixed(1) : Math.round(hAcc)} m · ${Math.round(age)} s ago`;
  $('gps-accuracy').dataset.accuracy = String(hAcc);
}

function renderQueue() {
  const counts = { waiting: 0, sending: 0, sent: 0, refused: 0, 'no-fix': 0 };
  for (const p of state.photos.values()) if (p.state in counts) counts[p.state]++;
  counts.waiting += counts['no-fix'];
  const el = $('queue-counts');
  Object.assign(el.dataset, { waiting: counts.waiting, sending: counts.sending, sent: counts.sent, noFix: counts['no-fix'] });
  const parts = [`${counts.waiting} waiting`];
  if (counts['no-fix']) parts.push(`${counts['no-fix']} for a fix`);
  if (counts.sending) parts.push('sending');
  parts.push(`${counts.sent} sent`);
  if (counts.refused) parts.push(`${counts.refused} refused`);
  el.textContent = parts.join(' · ');
  $('photo-badge').textContent = counts.waiting + counts.sending ? String(counts.waiting + counts.sending) : '';
}

function renderStatus() {
  renderGps();
  renderQueue();
  $('site-name').textContent = state.site || 'none yet';
  const version = state.model ? state.model.version : 0;
  $('model-version').dataset.version = String(version);
  $('model-version').textContent = version ? `model v${version}` : '';
  siteMap.setSelf(position.fix, position.heading);
  renderNextShot();
  if (position.fix) attachFixes();
  if (!state.site) findNearbySite();
  if (document.body.dataset.view === 'map') siteMap.draw();
}

// The feed's own state (LiveFeed's onState), kept apart from what is shown:
// the browser's offline event overrides it only while it lasts.
let feedState = 'connecting';

function setConnection(state) {
  feedState = state;
  showConnection();
}

function showConnection() {
  const shown = navigator.onLine ? feedState : 'offline';
  $('connection').dataset.state = shown;
  $('connection').textContent = shown;
}

/** The network is back or the app is in front again: try now, not after a back-off. */
function reconnectNow() {
  showConnection();
  if (feed) feed.reconnectNow();
  if (uploader) uploader.kick();
}

// ---- photos list ------------------------------------------------------------

async function thumbnailOf(photo) {
  if (state.objectUrls.has(photo.captureId)) return state.objectUrls.get(photo.captureId);
  let blob = photo.blob;
  if (!blob && photo.state === 'sent') {
    blob = await api.blob(`/v1/captures/${encodeURIComponent(serverIdOf(photo))}/thumbnail.jpg?size=128`).catch(() => null);
  }
  if (!blob) return '';
  const url = URL.createObjectURL(blob);
  state.objectUrls.set(photo.captureId, url);
  return url;
}

function photoRow(photo) {
  let li = document.querySelector(`#photos li[data-capture="${photo.captureId}"]`);
  if (!li) {
    li = document.createElement('li');
    li.dataset.capture = photo.captureId;
    li.innerHTML = '<img alt=""><span class="photo-state"></span><span class="photo-id"></span>';
    li.addEventListener('click', () => openSeeThrough(li.dataset.capture));
    $('photos').prepend(li);
    thumbnailOf(photo).then((url) => { if (url) li.querySelector('img').src = url; });
  }
  return li;
}

function renderPhoto(photo) {
  state.photos.set(photo.captureId, photo);
  const li = photoRow(photo);
  const { label, tone } = describe(photo);
  Object.assign(li.dataset, { state: photo.state, status: photo.status || '', tone, serverId: serverIdOf(photo) });
  li.querySelector('.photo-state').textContent = label;
  li.querySelector('.photo-id').textContent = `${photo.captureId} · ${new Date(photo.takenAt).toLocaleTimeString()}`;
  $('no-photos').hidden = state.photos.size > 0;
  renderQueue();
  if (state.shown === photo.captureId) renderSeeThroughCaption(photo);
}

// ---- capture ----------------------------------------------------------------

function cameraIdFor(width, height) {
  return `${state.device}-${width}x${height}`;
}

/** The camera document a photo names, created once with a prior focal length. */
const ensuredCameras = new Set();
async function ensureCamera(photo) {
  const id = photo.metadata.camera;
  if (ensuredCameras.has(id)) return;
  if (!(await api.doc(`cameras/${id}`))) {
    const focal = (PRIOR_FOCAL_35MM / 36) * Math.max(photo.width, photo.height);
    await api.request(`/v1/cameras/${encodeURIComponent(id)}`, {
      method: 'PUT',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({
        fx: focal, fy: focal, cx: (photo.width - 1) / 2, cy: (photo.height - 1) / 2,
        width: photo.width, height: photo.height, distortion: [0, 0, 0, 0, 0], source: 'estimated',
      }),
    });
  }
  ensuredCameras.add(id);
}

// A photo taken without a fix waits on the phone for the first fix within
// this long (the scout has not gone far), then goes without one: the
// server places it by the scout's other photos or asks for a site.
const FIX_WAIT_MS = 120000;

/**
 * Photos waiting for a position: each gets the first fix taken within
 * FIX_WAIT_MS of it and joins the queue; past that, it goes without one.
 */
const attachFixes = serialized(async () => {
  const now = Date.now();
  for (const photo of state.photos.values()) {
    if (photo.state !== 'no-fix') continue;
    const fix = position.fix;
    const fresh = fix && fix.time >= photo.takenAt - 1000 * MAX_FIX_AGE_S && fix.time <= photo.takenAt + FIX_WAIT_MS;
    if (!fresh && now < photo.takenAt + FIX_WAIT_MS) continue;
    const metadata = { ...photo.metadata };
    if (fresh) metadata.gps = position.metadata(fix.time);
    const record = await store.update(photo.captureId, { state: 'waiting', metadata });
    if (record) renderPhoto(record);
    uploader.kick();
  }
});

async function shoot() {
  const shutter = $('shutter');
  shutter.disabled = true;
  try {
    const shot = await camera.takePhoto();
    const now = Date.now();
    const gps = position.metadata(now);
    const record = await store.add((captureId) => ({
      blob: shot.blob, width: shot.width, height: shot.height, takenAt: now, state: gps ? 'waiting' : 'no-fix',
      metadata: {
        capture_id: captureId, filename: `${captureId}.jpg`, camera: cameraIdFor(shot.width, shot.height),
        taken: new Date(now).toISOString(), ...(gps ? { gps } : {}),
      },
    }));
    renderPhoto(record);
    uploader.kick();
  } catch (err) {
    showNotice(err.message);
  } finally {
    shutter.disabled = false;
  }
}

// ---- feedback from the engine -----------------------------------------------

/** A photo's capture document changed: its status, reason and site. */
/**
 * The id the server stored a photo under: "{scout}.{captureId}", as its
 * answer said (docs/api.md); the queue's own id before it was sent.
 */
function serverIdOf(photo) {
  return photo.serverId || photo.captureId;
}

async function refreshCapture(captureId) {
  const photo = state.photos.get(captureId);
  if (!photo || photo.state !== 'sent') return;
  const doc = await api.doc(`captures/${serverIdOf(photo)}`).catch(() => null);
  if (!doc) return;
  const attrs = doc.attrs || {};
  if (attrs.scout && !state.scout) {
    state.scout = attrs.scout;
    store.setSetting('scout', state.scout);
  }
  const changes = { status: attrs.status, reason: attrs.status_reason || '', site: attrs.site || '' };
  if (attrs.status === CaptureStatus.WITHDRAWN) changes.state = 'withdrawn';
  if (changes.site && changes.site !== state.site) chooseSite(changes.site);
  const record = await store.update(captureId, changes);
  if (record) renderPhoto(record);
  if (attrs.status === CaptureStatus.REGISTERED && state.model) stampVersions(state.model);
}

/** Photos registered in `model` that have no model version yet get its version. */
async function stampVersions(model) {
  const statuses = (model.attrs && model.attrs.captures) || {};
  for (const photo of state.photos.values()) {
    const status = statuses[serverIdOf(photo)];
    if (!status || photo.state !== 'sent') continue;
    const changes = {};
    if (status === CaptureStatus.REGISTERED && !photo.modelVersion) changes.modelVersion = model.version;
    if (status !== CaptureStatus.REGISTERED && photo.modelVersion) changes.modelVersion = 0;
    if (status !== photo.status && photo.status !== CaptureStatus.WITHDRAWN) changes.status = status;
    if (!Object.keys(changes).length) continue;
    const record = await store.update(photo.captureId, changes);
    if (record) renderPhoto(record);
  }
  const latest = [...state.photos.values()].reverse().find((p) => p.modelVersion);
  if (latest && latest.captureId !== state.overlayOf) loadLiveOverlay(latest.captureId);
}

// Before the scout's first photo is placed, the nearest site within this
// many metres of the fix is shown (its model, map and next shots), looked
// up at most every SITE_LOOKUP_MS.
const NEARBY_SITE_M = 200;
const SITE_LOOKUP_MS = 15000;
let siteLookedUp = 0;

/** The nearest site to the fix while no photo of the scout's is placed. */
const findNearbySite = serialized(async () => {
  const fix = position.fix;
  if (state.site || !fix || Date.now() - siteLookedUp < SITE_LOOKUP_MS) return;
  siteLookedUp = Date.now();
  const sites = await api.sites(fix, NEARBY_SITE_M).catch(() => []);
  let best = null;
  for (const doc of sites) {
    const gps = (doc.attrs || {}).gps;
    if (!gps) continue;
    const { east, north } = enuOf(fix, gps.lat, gps.lon);
    const d = Math.hypot(east, north);
    if (!best || d < best.d) best = { d, id: doc.path.split('/').pop() };
  }
  if (best && !state.site) chooseSite(best.id);
});

function chooseSite(site) {
  state.site = site;
  state.model = null;
  loadModel();
}

/** The current site's model: version, map cameras and points. */
const loadModel = serialized(async () => {
  if (!state.site) return;
  const model = await api.doc(`sites/${state.site}/model`).catch(() => null);
  if (!model) return;
  const fresh = !state.model || state.model.version !== model.version;
  state.model = model;
  renderStatus();
  if (!fresh) return;
  await stampVersions(model);
  await loadMapData(model);
});

async function loadMapData(model) {
  const captures = await api.captures(state.site).catch(() => []);
  const scoutOf = new Map(captures.map((c) => [c.path.split('/').pop(), (c.attrs || {}).scout]));
  siteMap.setModel(model.attrs || {}, (id) => scoutOf.get(id));
  const sparse = model.blobs && model.blobs.sparse;
  if (sparse) {
    const buffer = await api.download(`/v1/blobs/${sparse}`, () => {}).catch(() => null);
    if (buffer) siteMap.setPoints(parsePly(buffer).positions);
  }
  siteMap.setSelf(position.fix, position.heading);
  $('site-map').dataset.cameras = String(siteMap.cameras.length);
  $('site-map').dataset.scouts = [...siteMap.scouts].sort().join(',');
  renderLegend();
  await loadCoverage();
  if (document.body.dataset.view === 'map') siteMap.draw();
}

/** The site's coverage and next shots, ranked from where the scout is. */
async function loadCoverage() {
  const fix = position.fix;
  const near = fix ? `?near=${fix.lat.toFixed(7)},${fix.lon.toFixed(7)}` : '';
  const coverage = await api.json(`/v1/sites/${encodeURIComponent(state.site)}/coverage${near}`).catch(() => null);
  siteMap.setCoverage(coverage);
  const el = $('site-map');
  el.dataset.coverageCells = String(siteMap.coverage.cells.length);
  el.dataset.unseen = String(siteMap.coverage.unseen.length);
  el.dataset.suggestions = String(siteMap.coverage.suggestions.length);
  renderNextShot();
}

/** Each scout's name in the colour of their cameras on the map. */
function renderLegend() {
  const list = $('scout-legend');
  const colours = scoutColours(siteMap.scouts);
  list.replaceChildren(...[...colours].filter(([name]) => name).map(([name, colour]) => {
    const item = document.createElement('li');
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = colour;
    item.append(swatch, document.createTextNode(name === state.scout ? `${name} (you)` : name));
    item.dataset.scout = name;
    item.dataset.colour = colour;
    return item;
  }));
}

/**
 * The arrow over the camera view toward the first suggested shot: its
 * direction relative to where the phone points (to north without a
 * compass), the distance and the reason; at the spot, which way to look.
 */
function renderNextShot() {
  const el = $('next-shot');
  const next = siteMap.coverage.suggestions[0];
  const self = siteMap.self;
  if (!next || !self) {
    el.hidden = true;
    return;
  }
  const east = next.east - self.east, north = next.north - self.north;
  const metres = Math.hypot(east, north);
  const arrived = metres < Math.max(3, self.accuracy || 0);
  const bearing = arrived ? next.heading : ((Math.atan2(east, north) * 180) / Math.PI + 360) % 360;
  const facing = Number.isFinite(self.heading) ? self.heading : 0;
  $('next-shot-arrow').style.transform = `rotate(${bearing - facing}deg)`;
  $('next-shot-text').textContent = arrived
    ? `here: look ${Math.round(next.heading)}° · ${next.reason}`
    : `${Math.round(metres)} m · ${next.reason}`;
  Object.assign(el.dataset, { bearing: bearing.toFixed(0), distance: metres.toFixed(1), kind: next.kind });
  el.hidden = false;
}

const modelChanged = debounce(() => loadModel(), 300);

function onChange(change) {
  const path = change.path || '';
  const capture = /^\/captures\/([^/]+)$/.exec(path);
  const photo = capture && [...state.photos.values()].find((p) => serverIdOf(p) === capture[1]);
  if (photo) refreshCapture(photo.captureId);
  if (state.site && path === `/sites/${state.site}/model`) modelChanged();
}

let feed = null;
async function follow() {
  if (feed) feed.stop();
  feed = new LiveFeed({ token: tokens.get, onChange, onState: setConnection, pattern: '/**' });
  let since = 0;
  try {
    since = (await healthz()).last_seq || 0;
  } catch {
    // offline: the feed starts from 0 once the server is back
  }
  feed.start(since);
  for (const photo of state.photos.values()) {
    if (photo.state === 'sent' && photo.status !== CaptureStatus.WITHDRAWN) refreshCapture(photo.captureId);
  }
  if (state.site) loadModel();
}

// ---- AR: the model over the photo and over the live view --------------------

// draw 'mesh': the textured surface alone (opacity 100), which the
// see-through slider fades over the photo; 'points': the depth-coloured
// cloud blended by the server.
async function overlayUrl(captureId, maxSide, draw = 'points') {
  const id = serverIdOf(state.photos.get(captureId) || { captureId });
  const query = draw === 'mesh' ? `max_side=${maxSide}&draw=mesh&opacity=100` : `max_side=${maxSide}`;
  const blob = await api.blob(`/v1/captures/${encodeURIComponent(id)}/overlay.jpg?${query}`);
  return URL.createObjectURL(blob);
}

async function loadLiveOverlay(captureId) {
  state.overlayOf = captureId;
  try {
    const url = await overlayUrl(captureId, 1024);
    const img = $('live-overlay');
    if (img.src.startsWith('blob:')) URL.revokeObjectURL(img.src);
    img.src = url;
    img.dataset.capture = captureId;
  } catch {
    state.overlayOf = '';
  }
}

function toggleBlend() {
  const on = $('blend').getAttribute('aria-pressed') !== 'true';
  $('blend').setAttribute('aria-pressed', String(on));
  $('live-overlay').hidden = !on || !$('live-overlay').src;
}

function renderSeeThroughCaption(photo) {
  $('see-through-caption').textContent = `${photo.captureId}: ${describe(photo).label}`;
  $('withdraw').hidden = photo.state === 'withdrawn' || photo.state === 'refused';
}

async function openSeeThrough(captureId) {
  const photo = state.photos.get(captureId);
  if (!photo) return;
  state.shown = captureId;
  setView('see-through');
  renderSeeThroughCaption(photo);
  $('see-through-photo').src = await thumbnailOf(photo);
  await loadSeeThroughOverlay(photo);
}

// The shown photo's overlay as the switch asks; a site without a surface
// yet says so and shows its points.
async function loadSeeThroughOverlay(photo) {
  const overlay = $('see-through-overlay');
  overlay.hidden = true;
  overlay.removeAttribute('data-capture');
  overlay.removeAttribute('data-draw');
  if (photo.status !== CaptureStatus.REGISTERED) return;
  let draw = state.overlayDraw;
  let url = await overlayUrl(photo.captureId, 1280, draw).catch((err) => {
    if (draw === 'mesh') {
      $('see-through-caption').textContent =
        `${photo.captureId}: no surface yet (${err.message}); showing the points`;
    }
    return '';
  });
  if (!url && draw === 'mesh') {
    draw = 'points';
    url = await overlayUrl(photo.captureId, 1280, draw).catch(() => '');
  }
  if (state.shown !== photo.captureId) return;  // another photo opened meanwhile
  if (overlay.src.startsWith('blob:')) URL.revokeObjectURL(overlay.src);
  overlay.src = url;
  overlay.hidden = !url;
  if (url) {
    overlay.dataset.capture = photo.captureId;
    overlay.dataset.draw = draw;
  }
}

function setOverlayDraw(draw) {
  state.overlayDraw = draw;
  for (const b of document.querySelectorAll('#overlay-draw button')) {
    b.setAttribute('aria-pressed', String(b.dataset.draw === draw));
  }
  const photo = state.photos.get(state.shown);
  if (photo) {
    renderSeeThroughCaption(photo);
    loadSeeThroughOverlay(photo);
  }
}

async function withdrawShown() {
  const photo = state.photos.get(state.shown);
  if (!photo) return;
  try {
    if (photo.state === 'sent') {
      await api.request(`/v1/captures/${encodeURIComponent(serverIdOf(photo))}`, { method: 'DELETE' });
    }
    const record = await store.update(photo.captureId, { state: 'withdrawn', status: CaptureStatus.WITHDRAWN, blob: null, modelVersion: 0 });
    if (record) renderPhoto(record);
    setView('photos');
  } catch (err) {
    showNotice(`could not withdraw: ${err.message}`);
  }
}

// ---- views and start-up -----------------------------------------------------

function setView(view) {
  document.body.dataset.view = view;
  for (const b of document.querySelectorAll('#tabs button')) {
    if (b.dataset.view === view) b.setAttribute('aria-current', 'page');
    else b.removeAttribute('aria-current');
  }
  if (view === 'map') siteMap.draw();
}

function wire() {
  $('shutter').addEventListener('click', shoot);
  $('blend').addEventListener('click', toggleBlend);
  $('open-map').addEventListener('click', () => setView('map'));
  $('close-see-through').addEventListener('click', () => setView('photos'));
  $('withdraw').addEventListener('click', withdrawShown);
  for (const b of document.querySelectorAll('#overlay-draw button')) {
    b.addEventListener('click', () => setOverlayDraw(b.dataset.draw));
  }
  $('overlay-opacity').addEventListener('input', (e) => {
    $('see-through-overlay').style.opacity = String(e.target.value / 100);
  });
  for (const b of document.querySelectorAll('#tabs button')) {
    b.addEventListener('click', () => setView(b.dataset.view));
  }
  $('sign-in').addEventListener('close', onTokenEntered);
  $('notice-sign-in').addEventListener('click', () => askForToken());
  window.addEventListener('online', reconnectNow);
  window.addEventListener('offline', showConnection);
  document.addEventListener('visibilitychange', () => {
    if (document.visibilityState === 'visible') reconnectNow();
  });
  window.addEventListener('resize', debounce(() => siteMap.draw(), 200));
  setInterval(renderGps, 1000);
  // Photos waiting for a fix go without one after FIX_WAIT_MS.
  setInterval(attachFixes, 5000);
}

async function startCamera() {
  try {
    await camera.start();
    $('camera-problem').hidden = true;
  } catch (err) {
    $('camera-problem').textContent = err.message;
    $('camera-problem').hidden = false;
    $('shutter').disabled = true;
  }
}

async function main() {
  tokenFromAddress();
  wire();
  store = await PhotoStore.open();
  state.device = await store.deviceId();
  state.scout = await store.setting('scout', '');
  for (const photo of await store.all()) renderPhoto(photo);
  const placed = [...state.photos.values()].reverse().find((p) => p.site);
  if (placed) state.site = placed.site;
  uploader = new Uploader({
    store, token: tokens.get, prepare: ensureCamera,
    onChange: (record) => {
      renderPhoto(record);
      // An upload got through: the feed need not wait out its back-off.
      if (record.state === 'sent' && feedState !== 'live') reconnectNow();
    },
    onStopped: (message) => showNotice(message, { signIn: true }),
  });
  if ('serviceWorker' in navigator) navigator.serviceWorker.register('sw.js').catch(() => {});
  position.start();
  startCamera();
  if (!tokens.get()) askForToken();
  else {
    follow();
    uploader.kick();
    recheckToken();
  }
  renderStatus();
  document.body.dataset.ready = 'true';
}

main().catch((err) => showNotice(`the app failed to start: ${err.message}`));

