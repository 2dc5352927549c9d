// The 3D view: renderer, camera, orbit controls, the point cloud and the
// camera frusta. Renders on demand (after a change or a control move).

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { FrustumSet } from './frusta.js';

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
    this.material = new THREE.PointsMaterial({
      size: this.pointSizePx * this.renderer.getPixelRatio(),
      sizeAttenuation: false,
      vertexColors: true,
    });
    this.points = null;

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
    this.renderer.render(this.scene, this.camera);
  }

  /** Shows a parsed cloud ({count, positions, colors}), replacing the last. */
  setCloud(cloud) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(cloud.positions, 3));
    geometry.setAttribute('color', new THREE.BufferAttribute(cloud.colors, 3, true));
    if (this.points) {
      this.points.geometry.dispose();
      this.points.geometry = geometry;
    } else {
      this.points = new THREE.Points(geometry, this.material);
      this.scene.add(this.points);
    }
    this.renderNow();
  }

  clearCloud() {
    if (!this.points) return;
    this.scene.remove(this.points);
    this.points.geometry.dispose();
    this.points = null;
    this.requestRender();
  }

  get pointCount() {
    return this.points ? this.points.geometry.getAttribute('position').count : 0;
  }

  setPointSize(px) {
    this.pointSizePx = px;
    this.material.size = px * this.renderer.getPixelRatio();
    this.requestRender();
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

  resetView() {
    if (!this.home) return;
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
