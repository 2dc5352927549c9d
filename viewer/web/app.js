// The arscout web viewer: sites, a site's model in 3D, live updates.
// This module holds the state and wires the others together.

import * as THREE from 'three';
import { ApiClient, ApiError, UnauthorizedError, healthz, tokenStore, encodePath } from './api.js';
import { Viewer, robustBounds } from './scene.js';
import { OctreeCloud, DEFAULT_POINT_BUDGET } from './lod.js';
import { MeshTiles } from './mesh.js';
import { Measurement } from './measure.js';
import { CONFIDENT_SUPPORT, shownAt } from './points_material.js';
import { ThumbnailCache, cameraCentre, cameraRotation, intrinsicsOf } from './frusta.js';
import { LiveFeed } from './live.js';
import { renderSites, markSelectedSite, captureStatuses, renderCaptures, siteId, siteHolding, liveSites } from './sites.js';
import { renderComponentLegend } from './components.js';
import { status, progress, tokenDialog, overlayDialog, viewMessage, showLiveState } from './ui.js';
import { debounce, serialized, formatCount, formatTime } from './util.js';

const $ = (id) => document.getElementById(id);

// The frusta's depth as a share of the cloud's (robust) size.
const FRUSTUM_SCALE = 0.04;
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
  display: 'points', // the user's choice of points, mesh or both
  framed: false, // the camera was framed on this site's cloud
  frustumDepth: 1,
  thumbnails: null,
  heightRange: null, // [lo, hi] of the cloud's sample: colour by height
};

const api = new ApiClient({
  onUnauthorized: () => askForToken('The server rejected the token (401). Please enter it again.'),
});
const viewer = new Viewer($('canvas-host'));
const measurement = new Measurement({
  labelHost: $('measure-labels'),
  requestRender: () => viewer.requestRender(),
  onChange: showMeasurement,
});
viewer.scene.add(measurement.group);
viewer.afterRender.push(() => {
  measurement.placeLabels((p) => viewer.toScreen(p));
  showDrawnCount();
  showMeshCount();
});
// For the browser tests and the console.
window.arscoutViewer = { viewer, measurement, state };
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
const LOAD_MESH = 'could not load the mesh';

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
  loadExportFormats().catch((err) => report(err, 'the export formats were not loaded'));
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
  const live = liveSites(state.sites);
  renderSites($('sites-body'), live, state.site, requestSite);
  $('sites-empty').hidden = live.length > 0 || !tokenStore.get();
  showSiteTitle();
}

/** The open site grew into another: that one opens in its place. */
function followMergedSite() {
  if (!state.site) return;
  const holder = siteHolding(state.sites, state.site);
  if (holder === state.site) return;
  const from = siteDoc(state.site)?.attrs?.name || state.site;
  requestSite(holder);
  status.show(`site ${from} grew into site ${siteDoc(holder)?.attrs?.name || holder}`);
}

const refreshSites = serialized(async () => {
  try {
    state.sites = await api.sites();
    status.clear(LOAD_SITES);
    renderSiteList();
    followMergedSite();
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
    onViewFrom: viewFromCapture,
  });
}

/** The model seen from a registered photo's pose ("view from this photo"). */
function viewFromCapture(id) {
  const attrs = state.model?.attrs || {};
  const image = (attrs.images || []).find((im) => im.id === id);
  if (!image || !Array.isArray(image.qvec)) return;
  const camera = intrinsicsOf(attrs, image);
  const fov = camera ? (2 * Math.atan(camera.height / (2 * camera.fy)) * 180) / Math.PI : 50;
  viewer.viewFrom(cameraCentre(image), cameraRotation(image), fov, 4 * state.frustumDepth);
  selectCapture(id);
  status.show(`the model seen from ${id}; reset returns to the site's view`);
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
    openSite(siteHolding(state.sites, decodeURIComponent(match[1])));
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
  // A measurement or a picked point of one site means nothing in another's
  // frame (issue 38: they stayed on screen after a switch).
  measurement.clear();
  clearPickedPoint();
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
  $('components').replaceChildren();
  $('components').hidden = true;
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
  const components = (attrs.components || []).length;
  if (components > 1) parts.push(`${components} components, apart until photos link them`);
  $('model-details').textContent = parts.join(' · ');
  renderComponentLegend($('components'), attrs);
}

/**
 * The clouds a model offers: the sparse one, and the dense one once the
 * engine has published one (attrs.dense_tiles, or one "dense" blob in
 * models written before tiles, empty until the first dense phase).
 */
function cloudKinds(doc) {
  const stats = doc?.attrs?.statistics || {};
  const tiles = doc?.attrs?.dense_tiles;
  const dense = Array.isArray(tiles) ? tiles.some((tile) => tile.blob) : Boolean(doc?.blobs?.dense);
  return {
    sparse: Boolean(doc?.blobs?.sparse),
    dense: dense && stats.dense_points !== 0,
  };
}

/** Which cloud to show: the user's choice if the model has it, else dense if present. */
function cloudKind(doc) {
  const kinds = cloudKinds(doc);
  if (state.chosenKind && kinds[state.chosenKind]) return state.chosenKind;
  return kinds.dense ? 'dense' : 'sparse';
}

/** True when the model names a textured mesh (a mesh tile with levels). */
function hasMesh(doc) {
  const tiles = doc?.attrs?.mesh_tiles;
  return Array.isArray(tiles) && tiles.some((tile) => Array.isArray(tile.levels) && tile.levels.length > 0);
}

/** The points / mesh / both switch, shown when the model has a mesh. */
function showDisplayControls(doc) {
  const mesh = hasMesh(doc);
  $('display-mode').hidden = !mesh;
  const mode = mesh ? state.display : 'points';
  for (const radio of document.querySelectorAll('input[name="display-mode"]')) radio.checked = radio.value === mode;
  viewer.setDisplay(mode);
}

function showKindControls(doc, kind) {
  const kinds = cloudKinds(doc);
  $('cloud-sparse').disabled = !kinds.sparse;
  $('cloud-dense').disabled = !kinds.dense;
  $('cloud-sparse').checked = kind === 'sparse';
  $('cloud-dense').checked = kind === 'dense';
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

// The root's points that are drawn: the view frames what the planner sees.
function shownPositions(sample) {
  if (!sample.support) return sample.positions;
  const kept = [];
  for (let i = 0; i < sample.count; i++) {
    if (shownAt(sample.support[i], viewer.minSupport)) {
      kept.push(sample.positions[3 * i], sample.positions[3 * i + 1], sample.positions[3 * i + 2]);
    }
  }
  return kept.length > 0 ? Float32Array.from(kept) : sample.positions;
}

function frameOn(sample, attrs) {
  const bounds = robustBounds(shownPositions(sample));
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
  showDisplayControls(null);
  $('model-details').textContent = '';
  $('components').replaceChildren();
  $('components').hidden = true;
  viewMessage('No model yet for this site.');
  renderCaptureList();
}

/** The 5th and 95th percentiles of a sample's heights (colour by height). */
function heightRange(sample) {
  const heights = [];
  const step = Math.max(1, Math.floor(sample.count / 50000));
  for (let i = 0; i < sample.count; i += step) heights.push(sample.positions[i * 3 + 2]);
  heights.sort((a, b) => a - b);
  const at = (q) => heights[Math.min(heights.length - 1, Math.round(q * (heights.length - 1)))];
  return heights.length ? [at(0.05), at(0.95)] : [0, 1];
}

/** The streamed cloud of the site's current model (lod.js), its root loaded. */
async function openOctree(site, kind, generation, signal) {
  const hierarchy = await api.json(
    `/v1/sites/${encodePath(site)}/octree?cloud=${kind}`, { signal });
  const lod = new OctreeCloud({
    hierarchy,
    material: viewer.material,
    fetchNode: (name, nodeSignal) => api.download(
      `/v1/sites/${encodePath(site)}/octree/${hierarchy.version}/${name}.bin?cloud=${hierarchy.cloud}`,
      () => {}, nodeSignal),
    onLoad: () => viewer.requestRender(),
    onError: (err) => {
      // 410: the server no longer serves that version; show the current one.
      if (err instanceof ApiError && err.status === 410 && generation === state.generation) {
        state.model = null;
        reloadModel();
      } else {
        report(err, LOAD_MODEL);
      }
    },
  });
  lod.budget = Number($('point-budget').value) || DEFAULT_POINT_BUDGET;
  await lod.rootReady;
  return lod;
}

/**
 * The model's textured mesh, streamed (mesh.js), in place of the last
 * version's (whose levels it keeps where their blobs are the same); none
 * when the model has no mesh.
 */
async function showMesh(doc, generation, signal) {
  if (!hasMesh(doc)) {
    viewer.setMesh(null);
    return;
  }
  if (viewer.mesh && viewer.mesh.version >= doc.version) return;
  const site = state.site;
  const listing = await api.json(`/v1/sites/${encodePath(site)}/mesh`, { signal });
  if (generation !== state.generation) return;
  const mesh = new MeshTiles({
    listing,
    previous: viewer.mesh,
    fetchLevel: (url, levelSignal) => api.download(url, () => {}, levelSignal),
    onLoad: () => viewer.requestRender(),
    onError: (err) => {
      // 410: a tile changed since the listing; show the current model.
      if (err instanceof ApiError && err.status === 410 && generation === state.generation) {
        state.model = null;
        reloadModel();
      } else {
        report(err, LOAD_MESH);
      }
    },
  });
  viewer.setMesh(mesh);
  status.clear(LOAD_MESH);
}

/** Puts a model document's cloud, mesh and frusta on screen. */
async function showModel(doc, generation, signal) {
  const kind = cloudKind(doc);
  showKindControls(doc, kind);
  showDisplayControls(doc);
  if (!cloudKinds(doc)[kind]) {
    viewer.clearCloud();
    state.model = doc;
    state.shownKind = kind;
    showModelVersion(doc.version);
    showPointCount(0, kind);
    showModelDetails(doc);
    viewMessage('This model has no point cloud.');
    return;
  }
  // The first request for a version builds its octree on the server:
  // seconds for tens of millions of points.
  if (!viewer.lod) viewMessage(`Preparing the ${kind} cloud...`);
  const lod = await openOctree(state.site, kind, generation, signal);
  if (generation !== state.generation) {
    lod.dispose();
    return;
  }
  const sample = lod.root;
  // The camera is framed once per site (on its first cloud with points);
  // later versions keep the user's view.
  if (!state.framed && sample?.count > 0) frameOn(sample, doc.attrs || {});
  if (sample?.count > 0) state.heightRange = heightRange(sample);
  applyColourMode();
  viewer.setLod(lod);
  showMesh(doc, generation, signal).catch((err) => {
    if (generation === state.generation) report(err, LOAD_MESH);
  });
  viewer.frusta.update(doc.attrs || {}, state.frustumDepth, state.thumbnails);
  state.model = doc;
  state.shownKind = kind;
  viewMessage(lod.totalPoints > 0 ? '' : 'The model has no points yet.');
  showModelVersion(doc.version);
  showPointCount(lod.totalPoints, kind);
  showModelDetails(doc);
  renderCaptureList();
  if (lod.totalPoints > 0) document.body.dataset.cloud = 'loaded';
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

// ---- view options and measurement --------------------------------------

/** Points drawn, and the nodes still on their way (streaming progress). */
function showDrawnCount() {
  const label = $('points-drawn');
  const drawn = viewer.pointCount;
  const loading = viewer.lod?.loading || 0;
  const text = (drawn ? `${formatCount(drawn)} drawn` : '') + (loading ? ` · loading ${loading} nodes` : '');
  if (label.textContent === text) return; // every frame: keep it cheap
  label.dataset.points = String(drawn);
  label.textContent = text;
}

/** Mesh triangles drawn, and the levels still on their way. */
function showMeshCount() {
  const label = $('mesh-drawn');
  const drawn = viewer.triangleCount;
  const loading = viewer.showsMesh ? viewer.mesh?.loading || 0 : 0;
  const text = (drawn ? `${formatCount(drawn)} triangles` : '') + (loading ? ` · loading ${loading} mesh levels` : '');
  if (label.textContent === text) return;
  label.dataset.triangles = String(drawn);
  label.textContent = text;
}

function applyColourMode() {
  viewer.setColourMode($('colour-mode').value, state.heightRange);
}

function showMeasurement(result) {
  const out = $('measure-result');
  out.textContent = measurement.summary();
  out.dataset.kind = result.kind || '';
  out.dataset.done = String(result.done);
  out.dataset.result = JSON.stringify(result);
  for (const button of document.querySelectorAll('#measure-tools button[data-tool]')) {
    button.classList.toggle('active', measurement.active && button.dataset.tool === result.kind);
  }
}

function clearPickedPoint() {
  const out = $('picked-point');
  out.textContent = '';
  for (const key of ['enu', 'crs', 'coordinates']) delete out.dataset[key];
}

/** The coordinates of a picked point in the chosen CRS, from the server. */
async function showPickedPoint(point) {
  const out = $('picked-point');
  const enu = `E ${point.x.toFixed(3)} N ${point.y.toFixed(3)} U ${point.z.toFixed(3)} (site ENU)`;
  out.textContent = enu;
  out.dataset.enu = JSON.stringify(point.toArray());
  if (!state.model?.attrs?.geo_registered) return;
  const query = new URLSearchParams({
    x: point.x, y: point.y, z: point.z, crs: $('crs').value.trim() || 'utm', heights: $('heights').value,
  });
  try {
    const p = await api.json(`/v1/sites/${encodePath(state.site)}/coordinates?${query}`);
    const [a, b, h] = p.coordinates;
    const where = p.geographic
      ? `lon ${a.toFixed(8)} lat ${b.toFixed(8)}`
      : `E ${a.toFixed(3)} N ${b.toFixed(3)}`;
    out.textContent = `${where} h ${h.toFixed(3)} (${p.crs}, ${p.crs_name}) · ${enu}`;
    out.dataset.crs = p.crs;
    out.dataset.coordinates = JSON.stringify(p.coordinates);
  } catch (err) {
    report(err, 'could not convert the point');
  }
}

/** A click (not a drag) on the view picks a point: for the tool, and shown. */
function wirePicking() {
  const canvas = viewer.canvas;
  let down = null;
  canvas.addEventListener('pointerdown', (e) => { down = { x: e.clientX, y: e.clientY }; });
  canvas.addEventListener('click', (e) => {
    if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > 4) return;
    down = null;
    // The second click of a double click finishes (below); it adds no point.
    if (e.detail > 1) return;
    const point = viewer.pick(e.clientX, e.clientY);
    if (!point) return;
    measurement.add(point);
    showPickedPoint(point);
  });
  canvas.addEventListener('dblclick', () => measurement.finish());
  window.addEventListener('keydown', (e) => {
    // A focused field or button takes its own keys.
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLButtonElement ||
        e.target instanceof HTMLSelectElement) return;
    if (e.key === 'Enter') measurement.finish();
    if (e.key === 'Escape') measurement.clear();
  });
}

function wireViewOptions() {
  for (const button of document.querySelectorAll('#measure-tools button[data-tool]')) {
    button.addEventListener('click', () => {
      measurement.start(button.dataset.tool);
      // Enter and Escape are the view's now, not this button's.
      button.blur();
    });
  }
  $('measure-finish').addEventListener('click', () => measurement.finish());
  $('measure-clear').addEventListener('click', () => measurement.clear());
  $('colour-mode').addEventListener('change', applyColourMode);
  $('edl').addEventListener('change', (e) => viewer.setEyeDomeLighting(e.target.checked));
  viewer.setEyeDomeLighting($('edl').checked);
  const applyConfidence = () =>
    viewer.setMinSupport($('hide-low-confidence').checked ? CONFIDENT_SUPPORT : 0);
  $('hide-low-confidence').addEventListener('change', applyConfidence);
  applyConfidence();
  $('point-budget').addEventListener('change', () => {
    if (viewer.lod) viewer.lod.budget = Number($('point-budget').value);
    viewer.requestRender();
  });
  wirePicking();
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
  for (const radio of document.querySelectorAll('input[name="display-mode"]')) {
    radio.addEventListener('change', () => {
      if (!radio.checked) return;
      state.display = radio.value;
      viewer.setDisplay(radio.value);
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
  overlayDialog.init();
  wireViewOptions();
  window.addEventListener('hashchange', () => {
    if (tokenStore.get()) openFromHash();
  });
}

/** The export formats as the server's registry lists them (GET
 * /v1/exports): one button each, with its summary as the tooltip. */
async function loadExportFormats() {
  const row = $('exports');
  if (row.childElementCount) return;
  const { formats } = await api.json('/v1/exports');
  for (const format of formats) {
    const button = document.createElement('button');
    button.type = 'button';
    button.dataset.format = format.name;
    button.textContent = format.name;
    button.title = format.summary + (format.options.includes('crs') ? ' (in the CRS and heights chosen above)' : '');
    button.addEventListener('click', () => exportSite(format));
    row.append(button);
  }
}

async function exportSite(format) {
  const id = state.site;
  if (!id) return;
  status.show(`exporting ${format.name}...`);
  try {
    const query = new URLSearchParams({ format: format.name });
    // A format in a chosen CRS takes the CRS and heights chosen for picked
    // points.
    if (format.options.includes('crs')) {
      query.set('crs', $('crs').value.trim() || 'utm');
      query.set('heights', $('heights').value);
    }
    const url = `/v1/sites/${encodePath(id)}/export?${query}`;
    const name = await api.saveAs(url, `${id}-${format.name}`, format.extension);
    status.show(`downloaded ${name}`);
  } catch (err) {
    report(err, `export ${format.name} failed`);
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
