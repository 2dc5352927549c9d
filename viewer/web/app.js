// The arscout web viewer: sites, a site's model in 3D, live updates.
// This module holds the state and wires the others together.

import * as THREE from 'three';
import { ApiClient, UnauthorizedError, healthz, tokenStore, encodePath } from './api.js';
import { parsePly } from './ply.js';
import { Viewer, robustBounds } from './scene.js';
import { ThumbnailCache, cameraCentre, cameraRotation } from './frusta.js';
import { LiveFeed } from './live.js';
import { renderSites, markSelectedSite, captureStatuses, renderCaptures, siteId } from './sites.js';
import { status, progress, tokenDialog, overlayDialog, viewMessage, showLiveState } from './ui.js';
import { debounce, serialized, formatCount, formatTime } from './util.js';

const $ = (id) => document.getElementById(id);

// The frusta's depth as a share of the cloud's (robust) size.
const FRUSTUM_SCALE = 0.04;
// Parsed blobs kept besides those of the cloud on screen.
const CLOUD_CACHE_EXTRA = 4;
const LIST_REFRESH_MS = 500;

const state = {
  lastSeq: 0, // from /healthz, before the first load
  sites: [], // the /sites/* documents
  captureDocs: [], // the open site's /captures/* documents
  site: null, // the open site's id
  generation: 0, // counts site openings: stale async results are dropped
  abort: null, // aborts the open site's downloads
  model: null, // the model document on screen
  shownKind: null, // 'sparse' | 'dense' on screen
  chosenKind: null, // the user's choice; null: dense when there is one
  framed: false, // the camera was framed on this site's cloud
  frustumDepth: 1,
  thumbnails: null,
};

const api = new ApiClient({
  onUnauthorized: () => askForToken('The server rejected the token (401). Please enter it again.'),
});
const viewer = new Viewer($('canvas-host'));
const feed = new LiveFeed({
  token: () => tokenStore.get(),
  onChange: handleChange,
  onState: (feedState, detail) => {
    showLiveState(feedState, detail);
    // Catch up once connected; while reconnecting, an HTTP call also finds
    // out whether the token still works.
    if (feedState === 'live') refreshLists();
    if (feedState === 'reconnecting') refreshSites();
  },
});

/** Shows a failure in the status line; `what` also keys its later clearing. */
function report(err, what) {
  if (err instanceof UnauthorizedError || err?.name === 'AbortError') return;
  console.warn(what, err);
  status.error(what ? `${what}: ${err.message}` : err.message, what);
}

const LOAD_SITES = 'could not load the sites';
const LOAD_CAPTURES = 'could not load the captures';
const LOAD_MODEL = 'could not load the model';

// ---- token ------------------------------------------------------------

function askForToken(message) {
  tokenStore.clear();
  feed.stop();
  $('sign-out').hidden = true;
  tokenDialog.open(message, (token) => {
    tokenStore.set(token);
    start();
  });
}

async function start() {
  $('sign-out').hidden = false;
  status.clear();
  await refreshSites();
  if (!tokenStore.get()) return; // the token was rejected
  feed.start(state.lastSeq);
  openFromHash();
}

function signOut() {
  closeSite();
  state.sites = [];
  state.captureDocs = [];
  renderSiteList();
  askForToken('Signed out. Enter a planner token to sign in again.');
}

// ---- sites --------------------------------------------------------------

function siteDoc(id) {
  return state.sites.find((doc) => siteId(doc) === id) || null;
}

function renderSiteList() {
  renderSites($('sites-body'), state.sites, state.site, requestSite);
  $('sites-empty').hidden = state.sites.length > 0 || !tokenStore.get();
  showSiteTitle();
}

const refreshSites = serialized(async () => {
  try {
    state.sites = await api.sites();
    status.clear(LOAD_SITES);
    renderSiteList();
    if (state.site) renderCaptureList();
  } catch (err) {
    report(err, LOAD_SITES);
  }
});

const refreshCaptures = serialized(async () => {
  const site = state.site;
  if (!site) return;
  try {
    const docs = await api.captures(site);
    if (state.site !== site) return; // another site was opened meanwhile
    state.captureDocs = docs;
    status.clear(LOAD_CAPTURES);
    renderCaptureList();
  } catch (err) {
    report(err, LOAD_CAPTURES);
  }
});

const refreshLists = debounce(() => {
  refreshSites();
  if (state.site) refreshCaptures();
}, LIST_REFRESH_MS);

function showSiteTitle() {
  const doc = state.site ? siteDoc(state.site) : null;
  $('site-title').textContent = state.site ? `site ${doc?.attrs?.name || state.site}` : '';
}

function renderCaptureList() {
  if (!state.site) return;
  const rows = captureStatuses(state.site, siteDoc(state.site), state.model, state.captureDocs);
  renderCaptures($('captures-body'), rows, {
    onSelect: selectCapture,
    onOverlay: (id) => overlayDialog.open(`overlay ${id}`,
      () => api.blob(`/v1/captures/${encodeURIComponent(id)}/overlay.jpg`)),
  });
}

function selectCapture(id) {
  for (const row of $('captures-body').rows) row.classList.toggle('selected', row.dataset.capture === id);
  viewer.frusta.highlight(id);
}

// ---- opening a site -----------------------------------------------------

function requestSite(id) {
  const hash = `#site=${encodeURIComponent(id)}`;
  if (location.hash !== hash) location.hash = hash; // hashchange opens it
  else openSite(id);
}

function openFromHash() {
  const match = /^#site=(.+)$/.exec(location.hash);
  if (!match) return;
  try {
    openSite(decodeURIComponent(match[1]));
  } catch {
    status.error(`bad site in the address: ${match[1]}`);
  }
}

function resetSiteState() {
  state.abort?.abort();
  state.abort = new AbortController();
  state.generation++;
  state.model = null;
  state.captureDocs = [];
  state.shownKind = null;
  state.framed = false;
  state.frustumDepth = 1;
  state.thumbnails?.dispose();
  state.thumbnails = null;
  viewer.clearCloud();
  viewer.frusta.clear();
  progress.hide();
}

function openSite(id) {
  if (id === state.site) return;
  resetSiteState();
  state.site = id;
  state.thumbnails = new ThumbnailCache(api);
  $('site-panel').hidden = false;
  $('captures-body').replaceChildren();
  showModelVersion(null);
  showPointCount(0, '');
  $('model-details').textContent = '';
  viewMessage('Loading the model...');
  markSelectedSite($('sites-body'), id);
  showSiteTitle();
  reloadModel();
  refreshCaptures();
}

function closeSite() {
  resetSiteState();
  state.site = null;
  $('site-panel').hidden = true;
  markSelectedSite($('sites-body'), null);
  showSiteTitle();
  viewMessage('Choose a site.');
}

// ---- the model ----------------------------------------------------------

function showModelVersion(version) {
  const badge = $('model-version');
  badge.dataset.version = String(version || 0);
  badge.textContent = version ? `model v${version}` : 'no model yet';
}

function showPointCount(count, kind) {
  const label = $('point-count');
  label.dataset.points = String(count);
  label.textContent = count ? `${formatCount(count)} ${kind} points` : '';
}

function showModelDetails(doc) {
  const attrs = doc.attrs || {};
  const stats = attrs.statistics || {};
  const parts = [
    attrs.frame === 'enu' ? 'ENU frame' : 'local frame',
    attrs.geo_registered ? 'geo-registered' : 'not geo-registered',
    `${stats.registered ?? 0} of ${stats.captures ?? 0} captures registered`,
  ];
  if (stats.pending) parts.push(`${stats.pending} pending`);
  if (stats.rejected) parts.push(`${stats.rejected} rejected`);
  parts.push(`dense ${attrs.dense_state || 'off'}`);
  parts.push(`updated ${formatTime(doc.updated)}`);
  $('model-details').textContent = parts.join(' · ');
}

/**
 * The blobs that hold a model's cloud: the sparse PLY, or the dense cloud's
 * tiles (attrs.dense_tiles; one "dense" blob in models written before
 * tiles). A tile that did not change keeps its blob, so a new version
 * downloads only the tiles that did.
 */
function cloudBlobs(doc, kind) {
  if (kind === 'dense' && Array.isArray(doc?.attrs?.dense_tiles)) {
    return doc.attrs.dense_tiles.map((tile) => tile.blob).filter(Boolean);
  }
  const hash = doc?.blobs?.[kind];
  return hash ? [hash] : [];
}

/**
 * The clouds a model offers. A model written before tiles carries an empty
 * dense PLY until its first dense phase: that one does not count.
 */
function cloudKinds(doc) {
  const stats = doc?.attrs?.statistics || {};
  return {
    sparse: cloudBlobs(doc, 'sparse').length > 0,
    dense: cloudBlobs(doc, 'dense').length > 0 && stats.dense_points !== 0,
  };
}

/** One cloud from several parsed ones (a dense cloud's tiles). */
function joinClouds(parts) {
  if (parts.length === 1) return parts[0];
  const count = parts.reduce((n, part) => n + part.count, 0);
  const positions = new Float32Array(count * 3);
  const colors = new Uint8Array(count * 3);
  let at = 0;
  for (const part of parts) {
    positions.set(part.positions.subarray(0, part.count * 3), at);
    colors.set(part.colors.subarray(0, part.count * 3), at);
    at += part.count * 3;
  }
  return { count, positions, colors };
}

/** Which cloud to show: the user's choice if the model has it, else dense if present. */
function cloudKind(doc) {
  const kinds = cloudKinds(doc);
  if (state.chosenKind && kinds[state.chosenKind]) return state.chosenKind;
  return kinds.dense ? 'dense' : 'sparse';
}

function showKindControls(doc, kind) {
  const kinds = cloudKinds(doc);
  $('cloud-sparse').disabled = !kinds.sparse;
  $('cloud-dense').disabled = !kinds.dense;
  $('cloud-sparse').checked = kind === 'sparse';
  $('cloud-dense').checked = kind === 'dense';
}

// Parsed clouds by blob hash (most recently used last).
const clouds = new Map();

function cloudFor(hash, label, signal) {
  let entry = clouds.get(hash);
  if (entry) {
    clouds.delete(hash);
  } else {
    entry = api.download(`/v1/blobs/${encodeURIComponent(hash)}`,
      (received, total) => progress.show(`loading ${label}`, received, total), signal)
      .then((buffer) => parsePly(buffer))
      .finally(() => progress.hide());
    entry.catch(() => clouds.delete(hash));
  }
  clouds.set(hash, entry);
  return entry;
}

/** Keeps the blobs of the cloud on screen and the few others used last. */
function pruneClouds(shown) {
  const others = [...clouds.keys()].filter((hash) => !shown.includes(hash));
  const stale = others.slice(0, Math.max(0, others.length - CLOUD_CACHE_EXTRA));
  for (const hash of stale) clouds.delete(hash);
}

/** The world's vertical: ENU's z, else the cameras' mean "up" (-y). */
function upVector(attrs) {
  if (attrs.frame === 'enu' || attrs.geo_registered) return new THREE.Vector3(0, 0, 1);
  const up = new THREE.Vector3();
  for (const image of attrs.images || []) {
    if (Array.isArray(image.qvec)) up.add(new THREE.Vector3(0, -1, 0).applyQuaternion(cameraRotation(image)));
  }
  return up.lengthSq() > 1e-6 ? up.normalize() : new THREE.Vector3(0, 0, 1);
}

/** Where to look from: the side the photos were taken from, a little raised. */
function viewDirection(attrs, centre, up) {
  const mean = new THREE.Vector3();
  let n = 0;
  for (const image of attrs.images || []) {
    if (!Array.isArray(image.qvec)) continue;
    mean.add(cameraCentre(image));
    n++;
  }
  const from = n ? mean.divideScalar(n).sub(centre) : new THREE.Vector3();
  from.addScaledVector(up, -from.dot(up)); // horizontal part
  if (from.lengthSq() < 1e-9) {
    from.set(0, -1, 0).addScaledVector(up, up.y); // south, levelled
    if (from.lengthSq() < 1e-9) from.set(1, 0, 0);
  }
  return from.normalize().addScaledVector(up, 0.45).normalize();
}

function frameOn(cloud, attrs) {
  const bounds = robustBounds(cloud.positions);
  const up = upVector(attrs);
  viewer.frame(bounds, viewDirection(attrs, bounds.centre, up), up);
  state.frustumDepth = bounds.size * FRUSTUM_SCALE;
  state.framed = true;
}

function showNoModel() {
  viewer.clearCloud();
  viewer.frusta.clear();
  state.model = null;
  state.shownKind = null;
  showModelVersion(null);
  showPointCount(0, '');
  showKindControls(null, null);
  $('model-details').textContent = '';
  viewMessage('No model yet for this site.');
  renderCaptureList();
}

/** Puts a model document's cloud and frusta on screen. */
async function showModel(doc, generation, signal) {
  const kind = cloudKind(doc);
  const hashes = cloudBlobs(doc, kind);
  showKindControls(doc, kind);
  if (hashes.length === 0) {
    viewer.clearCloud();
    state.model = doc;
    state.shownKind = kind;
    showModelVersion(doc.version);
    showPointCount(0, kind);
    showModelDetails(doc);
    viewMessage('This model has no point cloud.');
    return;
  }
  const cloud = joinClouds(await Promise.all(
    hashes.map((hash) => cloudFor(hash, `${kind} cloud`, signal))));
  pruneClouds(hashes);
  if (generation !== state.generation) return;
  // The camera is framed once per site (on its first cloud with points);
  // later versions keep the user's view.
  if (!state.framed && cloud.count > 0) frameOn(cloud, doc.attrs || {});
  viewer.setCloud(cloud);
  viewer.frusta.update(doc.attrs || {}, state.frustumDepth, state.thumbnails);
  state.model = doc;
  state.shownKind = kind;
  viewMessage(cloud.count > 0 ? '' : 'The model has no points yet.');
  showModelVersion(doc.version);
  showPointCount(cloud.count, kind);
  showModelDetails(doc);
  renderCaptureList();
  if (cloud.count > 0) document.body.dataset.cloud = 'loaded';
}

/** Fetches the open site's model and shows it if it is newer (or another kind). */
const reloadModel = serialized(async () => {
  const id = state.site;
  const generation = state.generation;
  const signal = state.abort?.signal;
  if (!id) return;
  try {
    const doc = await api.doc(`sites/${id}/model`);
    if (generation !== state.generation) return;
    status.clear(LOAD_MODEL);
    if (!doc) {
      showNoModel();
      return;
    }
    const current = state.model;
    if (current && doc.version <= current.version && cloudKind(doc) === state.shownKind) return;
    await showModel(doc, generation, signal);
  } catch (err) {
    if (generation === state.generation) report(err, LOAD_MODEL);
  }
});

// ---- live updates -------------------------------------------------------

function handleChange(change) {
  const path = change.path || '';
  if (state.site && path === `/sites/${state.site}/model`) {
    const shown = state.model?.version || 0;
    if (change.op === 'delete' || !(change.version <= shown)) reloadModel();
  }
  if (path.startsWith('/sites/') || path.startsWith('/captures/')) refreshLists();
}

// ---- controls -----------------------------------------------------------

function wireControls() {
  $('sign-out').addEventListener('click', signOut);
  for (const radio of document.querySelectorAll('input[name="cloud-kind"]')) {
    radio.addEventListener('change', () => {
      if (!radio.checked) return;
      state.chosenKind = radio.value;
      reloadModel();
    });
  }
  const size = $('point-size');
  size.addEventListener('input', () => {
    viewer.setPointSize(Number(size.value));
    $('point-size-value').textContent = `${size.value} px`;
  });
  viewer.setPointSize(Number(size.value));
  $('show-frusta').addEventListener('change', (event) => viewer.frusta.setVisible(event.target.checked));
  $('reset-view').addEventListener('click', () => viewer.resetView());
  for (const button of $('exports').querySelectorAll('button[data-format]')) {
    button.addEventListener('click', () => exportSite(button.dataset.format));
  }
  overlayDialog.init();
  window.addEventListener('hashchange', () => {
    if (tokenStore.get()) openFromHash();
  });
}

const EXPORT_EXTENSIONS = { ply: '.ply', 'ecef-ply': '.ply', geocsv: '.csv', colmap: '.tar' };

async function exportSite(format) {
  const id = state.site;
  if (!id) return;
  status.show(`exporting ${format}...`);
  try {
    const url = `/v1/sites/${encodePath(id)}/export?format=${encodeURIComponent(format)}`;
    const name = await api.saveAs(url, `${id}-${format}`, EXPORT_EXTENSIONS[format] || '');
    status.show(`downloaded ${name}`);
  } catch (err) {
    report(err, `export ${format} failed`);
  }
}

async function main() {
  wireControls();
  showLiveState('offline');
  viewMessage('Choose a site.');
  try {
    state.lastSeq = (await healthz()).last_seq || 0;
  } catch (err) {
    status.error(`the server is not reachable: ${err.message}`);
  }
  if (tokenStore.get()) start();
  else askForToken('Enter your planner token. It is kept for this browser session only.');
}

main();
