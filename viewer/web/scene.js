// The 3D view: renderer, camera, orbit controls, the streamed point cloud
// (lod.js) and textured mesh (mesh.js), shown alone or together,
// eye-dome lighting, picking and the camera frusta. Renders on demand
// (after a change, a control move or a node's or level's arrival).

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { FrustumSet } from './frusta.js';
import { createPointsMaterial, CONFIDENT_SUPPORT, shownAt } from './points_material.js';
import { EyeDomeLighting } from './edl.js';

// Point colours and thumbnails are sRGB bytes meant to be shown as they are:
// no colour management, no conversion on output.
THREE.ColorManagement.enabled = false;

const BACKGROUND = 0x16181c;
const FOV_DEG = 50;
const SAMPLE_LIMIT = 60000;

function percentile(sorted, q) {
  if (sorted.length === 0) return 0;
  const at = Math.min(sorted.length - 1, Math.max(0, Math.round(q * (sorted.length - 1))));
  return sorted[at];
}

/**
 * Outlier-tolerant bounds of a cloud from an even sample of its points:
 * the per-axis median as the centre, and the diagonal of the box between
 * the 5th and 95th percentiles as the size.
 * @param {Float32Array} positions x,y,z per point
 */
export function robustBounds(positions) {
  const count = positions.length / 3;
  const step = Math.max(1, Math.floor(count / SAMPLE_LIMIT));
  const axes = [[], [], []];
  for (let i = 0; i < count; i += step) {
    for (let a = 0; a < 3; a++) {
      const v = positions[i * 3 + a];
      if (Number.isFinite(v)) axes[a].push(v);
    }
  }
  const sorted = axes.map((values) => Float64Array.from(values).sort());
  const centre = new THREE.Vector3(...sorted.map((s) => percentile(s, 0.5)));
  const low = new THREE.Vector3(...sorted.map((s) => percentile(s, 0.05)));
  const high = new THREE.Vector3(...sorted.map((s) => percentile(s, 0.95)));
  const size = Math.max(high.distanceTo(low), 1e-3);
  return { centre, size };
}

export class Viewer {
  /** @param {HTMLElement} host the element the canvas fills */
  constructor(host) {
    this.host = host;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(BACKGROUND, 1);
    host.append(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(FOV_DEG, 1, 0.01, 1000);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(0, -10, 5);
    this.controls = null;
    this.makeControls(new THREE.Vector3());

    this.pointSizePx = 2;
    this.material = createPointsMaterial();
    this.minSupport = CONFIDENT_SUPPORT;
    this.material.setSize(this.pointSizePx * this.renderer.getPixelRatio());
    this.lod = null; // the OctreeCloud on screen
    this.mesh = null; // the MeshTiles on screen
    this.display = 'points'; // 'points' | 'mesh' | 'both'
    this.edl = new EyeDomeLighting();
    this.afterRender = []; // callbacks (camera) after each frame: labels

    this.frusta = new FrustumSet(() => this.requestRender());
    this.scene.add(this.frusta.group);

    this.home = null;
    this.frameRequested = false;
    new ResizeObserver(() => this.resize()).observe(host);
    this.resize();
  }

  makeControls(target) {
    // OrbitControls fixes its notion of "up" when constructed.
    this.controls?.dispose();
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.copy(target);
    this.controls.screenSpacePanning = true;
    this.controls.zoomToCursor = true;
    this.controls.addEventListener('change', () => this.requestRender());
    this.controls.update();
  }

  resize() {
    const width = Math.max(1, this.host.clientWidth);
    const height = Math.max(1, this.host.clientHeight);
    this.renderer.setSize(width, height);
    const buffer = this.renderer.getDrawingBufferSize(new THREE.Vector2());
    this.edl.setSize(buffer.x, buffer.y);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.renderNow();
  }

  requestRender() {
    if (this.frameRequested) return;
    this.frameRequested = true;
    requestAnimationFrame(() => this.renderNow());
  }

  renderNow() {
    this.frameRequested = false;
    this.camera.updateMatrixWorld();
    const heightPx = this.renderer.getDrawingBufferSize(new THREE.Vector2()).y;
    // What is hidden is neither ranked nor fetched.
    if (this.lod && this.showsPoints) this.lod.update(this.camera, heightPx);
    if (this.mesh && this.showsMesh) this.mesh.update(this.camera, heightPx);
    if (this.edl.enabled) this.edl.render(this.renderer, this.scene, this.camera);
    else this.renderer.render(this.scene, this.camera);
    for (const callback of this.afterRender) callback(this.camera);
  }

  /**
   * Renders `count` frames, each waited for on the GPU (a one-pixel read),
   * and returns their times in milliseconds: the viewer's frame cost.
   */
  timeFrames(count) {
    const gl = this.renderer.getContext();
    const pixel = new Uint8Array(4);
    const times = [];
    for (let i = 0; i < count; i++) {
      const start = performance.now();
      this.renderNow();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
      times.push(performance.now() - start);
    }
    return times;
  }

  /** Shows a streamed cloud (lod.js), replacing the last one. */
  setLod(lod) {
    if (this.lod) {
      this.scene.remove(this.lod.group);
      this.lod.dispose();
    }
    this.lod = lod;
    if (lod) this.scene.add(lod.group);
    this.setDisplay(this.display);
  }

  /** Shows a streamed mesh (mesh.js), replacing the last one (null: none). */
  setMesh(mesh) {
    if (this.mesh && this.mesh !== mesh) {
      this.scene.remove(this.mesh.group);
      this.mesh.dispose();
    }
    this.mesh = mesh;
    if (mesh) this.scene.add(mesh.group);
    this.setDisplay(this.display);
  }

  clearCloud() {
    this.setLod(null);
    this.setMesh(null);
  }

  /** 'points', 'mesh' or 'both': what of the model is drawn. */
  setDisplay(mode) {
    this.display = mode;
    if (this.lod) this.lod.group.visible = this.showsPoints;
    if (this.mesh) this.mesh.group.visible = this.showsMesh;
    this.requestRender();
  }

  get showsPoints() {
    return this.display !== 'mesh';
  }

  get showsMesh() {
    return this.display !== 'points';
  }

  /** Points drawn in the last frame. */
  get pointCount() {
    return this.lod && this.showsPoints ? this.lod.drawnPoints : 0;
  }

  /** Mesh triangles drawn in the last frame. */
  get triangleCount() {
    return this.mesh && this.showsMesh ? this.mesh.drawnTriangles : 0;
  }

  setPointSize(px) {
    this.pointSizePx = px;
    this.material.setSize(px * this.renderer.getPixelRatio());
    this.requestRender();
  }

  /** 'rgb' or 'height' (between `range`'s two heights, metres). */
  setColourMode(mode, range) {
    this.material.setMode(mode);
    if (range) this.material.setHeightRange(range[0], range[1]);
    this.requestRender();
  }

  /**
   * Hides the fused points measured by fewer than `n` depth maps, from the
   * picture and from picking (0 shows every point).
   */
  setMinSupport(n) {
    this.minSupport = n;
    this.material.setMinSupport(n);
    this.requestRender();
  }

  setEyeDomeLighting(enabled) {
    this.edl.enabled = enabled;
    this.requestRender();
  }

  /**
   * What a click at the canvas position (clientX, clientY) picks: a drawn
   * point (pickPoint) where the points are shown, else the drawn mesh's
   * surface under the cursor; null when there is neither.
   */
  pick(clientX, clientY, radiusPx = 12) {
    const point = this.showsPoints ? this.pickPoint(clientX, clientY, radiusPx) : null;
    return point || (this.showsMesh ? this.pickMesh(clientX, clientY) : null);
  }

  /** The nearest surface of the drawn mesh levels under the cursor, or null. */
  pickMesh(clientX, clientY) {
    if (!this.mesh) return null;
    const rect = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(
      ((clientX - rect.left) / rect.width) * 2 - 1, 1 - ((clientY - rect.top) / rect.height) * 2);
    const raycaster = new THREE.Raycaster();
    raycaster.setFromCamera(ndc, this.camera);
    const hit = raycaster.intersectObjects(this.mesh.visibleMeshes(), false)[0];
    return hit ? hit.point.clone() : null;
  }

  /**
   * The drawn point nearest the canvas position (clientX, clientY) within
   * `radiusPx` (low-confidence points hidden by setMinSupport are not
   * drawn, so not candidates), among those not hidden on screen: a point is hidden when a
   * nearer one (by 1 % of the depth and 5 cm) is drawn within a point's
   * size of it, as its square would cover it. So a click snaps to what is
   * seen, not to a point behind a surface; null when no point is that
   * close.
   */
  pickPoint(clientX, clientY, radiusPx = 12) {
    if (!this.lod) return null;
    const rect = this.canvas.getBoundingClientRect();
    const candidates = this.pointsNear(clientX - rect.left, clientY - rect.top, rect, radiusPx);
    const cover = Math.max(1, Math.round(this.pointSizePx));
    const nearest = new Map(); // least depth by whole pixel
    const cell = (x, y) => `${x},${y}`;
    for (const c of candidates) {
      const key = cell(Math.floor(c.sx), Math.floor(c.sy));
      nearest.set(key, Math.min(nearest.get(key) ?? Infinity, c.depth));
    }
    const hidden = (c) => {
      const limit = c.depth - Math.max(0.05, 0.01 * c.depth);
      const x0 = Math.floor(c.sx), y0 = Math.floor(c.sy);
      for (let y = y0 - cover; y <= y0 + cover; y++) {
        for (let x = x0 - cover; x <= x0 + cover; x++) {
          if ((nearest.get(cell(x, y)) ?? Infinity) < limit) return true;
        }
      }
      return false;
    };
    let best = null;
    for (const c of candidates) {
      if ((!best || c.d2 < best.d2) && !hidden(c)) best = c;
    }
    return best && new THREE.Vector3().fromArray(best.positions, best.i);
  }

  /** The drawn points within radiusPx of (px, py), canvas pixels. */
  pointsNear(px, py, rect, radiusPx) {
    const viewProjection = new THREE.Matrix4().multiplyMatrices(
      this.camera.projectionMatrix, this.camera.matrixWorldInverse);
    const candidates = [];
    const p = new THREE.Vector4();
    for (const object of this.lod.visibleObjects()) {
      const positions = object.geometry.getAttribute('position').array;
      const support = object.geometry.getAttribute('support')?.array;
      for (let i = 0; i < positions.length; i += 3) {
        if (support && !shownAt(support[i / 3], this.minSupport)) continue;
        p.set(positions[i], positions[i + 1], positions[i + 2], 1).applyMatrix4(viewProjection);
        if (p.w <= 0) continue;
        const dx = ((p.x / p.w + 1) / 2) * rect.width - px;
        const dy = ((1 - p.y / p.w) / 2) * rect.height - py;
        const d2 = dx * dx + dy * dy;
        if (d2 <= radiusPx * radiusPx) candidates.push({ d2, sx: dx, sy: dy, depth: p.w, positions, i });
      }
    }
    return candidates;
  }

  /** Canvas pixel position of a world point (for labels); null behind the eye. */
  toScreen(point) {
    const p = new THREE.Vector4(point.x, point.y, point.z, 1)
      .applyMatrix4(this.camera.matrixWorldInverse).applyMatrix4(this.camera.projectionMatrix);
    if (p.w <= 0) return null;
    const rect = this.canvas.getBoundingClientRect();
    return { x: ((p.x / p.w + 1) / 2) * rect.width, y: ((1 - p.y / p.w) / 2) * rect.height };
  }

  /**
   * Points the camera at `centre` from the direction `from` (a unit vector
   * from the centre towards the eye) at a distance that fits `size`, with
   * `up` as the vertical; keeps this as the view "reset" returns to.
   */
  frame({ centre, size }, from, up) {
    const distance = (size * 0.6) / Math.tan(THREE.MathUtils.degToRad(FOV_DEG / 2));
    this.camera.up.copy(up).normalize();
    this.camera.position.copy(centre).addScaledVector(from.clone().normalize(), distance);
    this.camera.near = size / 1000;
    this.camera.far = distance + size * 100;
    this.camera.updateProjectionMatrix();
    this.camera.lookAt(centre);
    this.makeControls(centre);
    this.home = { position: this.camera.position.clone(), target: centre.clone(), up: this.camera.up.clone() };
    this.requestRender();
  }

  /**
   * Puts the eye at a photo's pose: its centre, looking where it looked,
   * with its vertical field of view (`fovDeg`) and its roll; orbiting
   * then turns about a point `depth` in front of it. "Reset" returns to
   * the site's view and field of view.
   */
  viewFrom(centre, rotation, fovDeg, depth) {
    // OpenCV camera axes (x right, y down, z forward) to three.js's (y up,
    // looking down -z).
    const forward = new THREE.Vector3(0, 0, 1).applyQuaternion(rotation);
    this.camera.up.copy(new THREE.Vector3(0, -1, 0).applyQuaternion(rotation));
    this.camera.position.copy(centre);
    this.camera.fov = fovDeg;
    this.camera.updateProjectionMatrix();
    const target = centre.clone().addScaledVector(forward, depth);
    this.camera.lookAt(target);
    this.makeControls(target);
    this.requestRender();
  }

  resetView() {
    if (!this.home) return;
    this.camera.fov = FOV_DEG;
    this.camera.updateProjectionMatrix();
    this.camera.up.copy(this.home.up);
    this.camera.position.copy(this.home.position);
    this.controls.target.copy(this.home.target);
    this.controls.update();
    this.requestRender();
  }

  /** The canvas, for pixel reads and screenshots. */
  get canvas() {
    return this.renderer.domElement;
  }
}
