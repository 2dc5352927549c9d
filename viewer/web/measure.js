// Measurement tools on the cloud, in metres of the site's ENU frame (z up):
//   distance  a polyline: each segment's length and the total
//   height    two points: their height difference, and horizontal and
//             straight distance
//   area      a polygon: its area on the ground plan (what a map shows)
//             and on its own best-fit plane (a facade's or a roof's)
// Clicked points snap to the drawn point nearest the cursor (Viewer.pick).

import * as THREE from 'three';

export const TOOLS = ['distance', 'height', 'area'];
const LINE_COLOUR = 0xffd23f;

/** Segment lengths and their sum. */
export function polylineLengths(points) {
  const segments = [];
  for (let i = 1; i < points.length; i++) segments.push(points[i].distanceTo(points[i - 1]));
  return { segments, total: segments.reduce((a, b) => a + b, 0) };
}

/** From a to b: rise (b above a, metres), horizontal and straight distance. */
export function heightDifference(a, b) {
  return {
    dz: b.z - a.z,
    horizontal: Math.hypot(b.x - a.x, b.y - a.y),
    straight: a.distanceTo(b),
  };
}

/**
 * A closed polygon's area on the plan (x, y: the shoelace formula) and on
 * its best-fit plane (half the length of Newell's normal).
 */
export function polygonAreas(points) {
  let plan = 0;
  const normal = new THREE.Vector3();
  for (let i = 0; i < points.length; i++) {
    const a = points[i], b = points[(i + 1) % points.length];
    plan += a.x * b.y - b.x * a.y;
    normal.x += (a.y - b.y) * (a.z + b.z);
    normal.y += (a.z - b.z) * (a.x + b.x);
    normal.z += (a.x - b.x) * (a.y + b.y);
  }
  return { plan: Math.abs(plan) / 2, surface: normal.length() / 2 };
}

export function formatMetres(m) {
  return `${m.toFixed(Math.abs(m) < 100 ? 3 : 2)} m`;
}

export class Measurement {
  /**
   * @param {object} options
   * @param {HTMLElement} options.labelHost where the labels go (over the canvas)
   * @param {(camera) => void} options.requestRender
   * @param {(result) => void} options.onChange the result after each point
   */
  constructor({ labelHost, requestRender, onChange }) {
    this.labelHost = labelHost;
    this.requestRender = requestRender;
    this.onChange = onChange;
    this.group = new THREE.Group();
    this.group.renderOrder = 10;
    this.kind = null;
    this.points = [];
    this.done = false;
    this.labels = [];
  }

  /** Starts a new measurement with one of TOOLS (clears the last one). */
  start(kind) {
    if (!TOOLS.includes(kind)) throw new Error(`unknown measurement tool ${kind}`);
    this.clear();
    this.kind = kind;
  }

  get active() {
    return this.kind !== null && !this.done;
  }

  add(point) {
    if (!this.active) return;
    this.points.push(point.clone());
    if (this.kind === 'height' && this.points.length === 2) this.done = true;
    this.redraw();
  }

  /** Ends a distance or area measurement (a double click, Enter). */
  finish() {
    if (!this.active) return;
    const enough = this.kind === 'area' ? 3 : 2;
    if (this.points.length >= enough) this.done = true;
    this.redraw();
  }

  clear() {
    this.kind = null;
    this.points = [];
    this.done = false;
    this.redraw();
  }

  /** What is measured so far: {kind, points, done, ...the tool's figures}. */
  get result() {
    const base = { kind: this.kind, done: this.done, points: this.points.map((p) => p.toArray()) };
    if (this.kind === 'distance') return { ...base, ...polylineLengths(this.points) };
    if (this.kind === 'height' && this.points.length === 2) {
      return { ...base, ...heightDifference(this.points[0], this.points[1]) };
    }
    if (this.kind === 'area' && this.points.length >= 3) return { ...base, ...polygonAreas(this.points) };
    return base;
  }

  /** One line for the panel. */
  summary() {
    const r = this.result;
    if (r.kind === 'distance' && this.points.length >= 2) return `distance ${formatMetres(r.total)}`;
    if (r.kind === 'height' && r.dz !== undefined) {
      return `height ${formatMetres(r.dz)} (horizontal ${formatMetres(r.horizontal)}, straight ${formatMetres(r.straight)})`;
    }
    if (r.kind === 'area' && r.plan !== undefined) {
      return `area ${r.plan.toFixed(2)} m² on the plan, ${r.surface.toFixed(2)} m² on its plane`;
    }
    if (r.kind) return `${r.kind}: click points on the cloud${r.kind === 'height' ? '' : ', double-click to finish'}`;
    return '';
  }

  redraw() {
    for (const child of [...this.group.children]) {
      child.geometry.dispose();
      child.material.dispose();
      this.group.remove(child);
    }
    for (const label of this.labels) label.element.remove();
    this.labels = [];
    if (this.points.length > 0) this.drawShape();
    this.onChange(this.result);
    this.requestRender();
  }

  drawShape() {
    const onTop = { depthTest: false, depthWrite: false, transparent: true };
    const closed = this.kind === 'area' && this.points.length >= 3;
    const path = closed ? [...this.points, this.points[0]] : [...this.points];
    if (this.kind === 'height' && this.points.length === 2) {
      // The vertical and the horizontal legs, so the rise reads at a glance.
      const [a, b] = this.points;
      const corner = new THREE.Vector3(b.x, b.y, a.z);
      path.splice(0, path.length, a, corner, b, a);
    }
    const geometry = new THREE.BufferGeometry().setFromPoints(path);
    this.group.add(new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: LINE_COLOUR, ...onTop })));
    const markers = new THREE.BufferGeometry().setFromPoints(this.points);
    this.group.add(new THREE.Points(markers, new THREE.PointsMaterial({
      color: 0xffffff, size: 9, sizeAttenuation: false, ...onTop,
    })));
    this.addLabels();
  }

  addLabels() {
    const r = this.result;
    if (this.kind === 'distance') {
      r.segments.forEach((length, i) => this.label(
        this.points[i].clone().lerp(this.points[i + 1], 0.5), formatMetres(length)));
    } else if (this.kind === 'height' && r.dz !== undefined) {
      const [a, b] = this.points;
      this.label(new THREE.Vector3(b.x, b.y, (a.z + b.z) / 2), `Δh ${formatMetres(r.dz)}`);
    } else if (this.kind === 'area' && r.plan !== undefined) {
      const centre = this.points.reduce((c, p) => c.add(p), new THREE.Vector3()).divideScalar(this.points.length);
      this.label(centre, `${r.plan.toFixed(2)} m²`);
    }
  }

  label(at, text) {
    const element = document.createElement('div');
    element.className = 'measure-label';
    element.textContent = text;
    this.labelHost.append(element);
    this.labels.push({ at, element });
  }

  /** Moves the labels to their points' places on screen (after a frame). */
  placeLabels(toScreen) {
    for (const { at, element } of this.labels) {
      const p = toScreen(at);
      element.hidden = !p;
      if (p) element.style.transform = `translate(${p.x}px, ${p.y}px) translate(-50%, -120%)`;
    }
  }
}
