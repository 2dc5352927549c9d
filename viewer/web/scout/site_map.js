// A small top-down map of the site, north up: the sparse points, every
// scout's cameras (a colour per scout, each with its viewing wedge) and
// the scout's own position, accuracy circle and heading.
//
// Where coverage is thin shows as darkness: each camera's wedge is drawn
// faintly and the wedges add up, so ground seen by many photos is bright
// and ground seen by one or none stays dark.

const WEDGE_M = 12; // how far a wedge reaches, metres
const EARTH_RADIUS_M = 6378137;

/** A stable colour for a scout's name. */
export function scoutColour(name) {
  let h = 0;
  for (const c of String(name)) h = (h * 31 + c.codePointAt(0)) % 360;
  return `hsl(${h}, 85%, 60%)`;
}

/**
 * East and north metres of (lat, lon) from the model's ENU origin; a local
 * tangent plane, good to centimetres over a site's few hundred metres.
 */
export function enuOf(origin, lat, lon) {
  const rad = Math.PI / 180;
  return {
    east: (lon - origin.lon) * rad * EARTH_RADIUS_M * Math.cos(origin.lat * rad),
    north: (lat - origin.lat) * rad * EARTH_RADIUS_M,
  };
}

/** The direction a camera looks, as (east, north), from its qvec (w x y z). */
function lookDirection(q) {
  const [w, x, y, z] = q;
  // Third row of the world-to-camera rotation: the optical axis in world.
  return { east: 2 * (x * z - w * y), north: 2 * (y * z + w * x) };
}

function percentile(sorted, p) {
  return sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))] : 0;
}

export class SiteMap {
  /** @param {HTMLCanvasElement} canvas */
  constructor(canvas) {
    this.canvas = canvas;
    this.cameras = []; // { id, east, north, look, fov, scout }
    this.points = new Float32Array(0); // east, north pairs
    this.self = null; // { east, north, accuracy, heading }
    this.scouts = new Set();
  }

  /** The model document's images placed on the map, with their scouts. */
  setModel(attrs, scoutOf) {
    const cameras = new Map((attrs.cameras || []).map((c) => [c.id, c]));
    this.cameras = [];
    this.scouts = new Set();
    for (const image of attrs.images || []) {
      if (!image.centre || !image.qvec) continue;
      const camera = cameras.get(image.camera);
      const fov = camera ? 2 * Math.atan(camera.width / (2 * camera.fx)) : Math.PI / 3;
      const scout = scoutOf(image.id) || '';
      this.scouts.add(scout);
      this.cameras.push({
        id: image.id, east: image.centre[0], north: image.centre[1],
        look: lookDirection(image.qvec), fov, scout,
      });
    }
    this.origin = attrs.frame === 'enu' ? attrs.enu_origin : null;
  }

  /** x y z triples (the sparse cloud) reduced to east, north pairs. */
  setPoints(positions) {
    const n = Math.floor(positions.length / 3);
    this.points = new Float32Array(2 * n);
    for (let i = 0; i < n; i++) {
      this.points[2 * i] = positions[3 * i];
      this.points[2 * i + 1] = positions[3 * i + 1];
    }
  }

  /** The scout's own fix, placed where the model has a geographic frame. */
  setSelf(fix, heading) {
    if (!fix || !this.origin) {
      this.self = null;
      return;
    }
    this.self = { ...enuOf(this.origin, fix.lat, fix.lon), accuracy: fix.hAcc, heading };
  }

  /** Metres -> canvas pixels: a frame holding most points and every camera. */
  frame(width, height) {
    const es = [], ns = [];
    for (let i = 0; i < this.points.length; i += 2) {
      es.push(this.points[i]);
      ns.push(this.points[i + 1]);
    }
    es.sort((a, b) => a - b);
    ns.sort((a, b) => a - b);
    let minE = percentile(es, 0.02), maxE = percentile(es, 0.98);
    let minN = percentile(ns, 0.02), maxN = percentile(ns, 0.98);
    const extra = this.cameras.map((c) => [c.east, c.north]);
    if (this.self) extra.push([this.self.east, this.self.north]);
    if (!es.length && extra.length) [minE, minN, maxE, maxN] = [...extra[0], ...extra[0]];
    for (const [e, n] of extra) {
      minE = Math.min(minE, e); maxE = Math.max(maxE, e);
      minN = Math.min(minN, n); maxN = Math.max(maxN, n);
    }
    const span = Math.max(maxE - minE, maxN - minN, 10);
    const scale = (0.9 * Math.min(width, height)) / span;
    const cx = (minE + maxE) / 2, cy = (minN + maxN) / 2;
    return {
      scale,
      x: (e) => width / 2 + (e - cx) * scale,
      y: (n) => height / 2 - (n - cy) * scale,
    };
  }

  draw() {
    const ratio = window.devicePixelRatio || 1;
    const width = this.canvas.clientWidth, height = this.canvas.clientHeight;
    if (!width || !height) return;
    this.canvas.width = Math.round(width * ratio);
    this.canvas.height = Math.round(height * ratio);
    const g = this.canvas.getContext('2d');
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.fillStyle = '#0b0f14';
    g.fillRect(0, 0, width, height);
    if (!this.cameras.length && !this.self) return;
    const f = this.frame(width, height);
    this.drawCoverage(g, f);
    this.drawPoints(g, f);
    this.drawCameras(g, f);
    this.drawSelf(g, f);
    this.drawScale(g, f, width, height);
  }

  drawCoverage(g, f) {
    g.save();
    g.globalCompositeOperation = 'lighter';
    g.fillStyle = 'rgba(60, 90, 130, 0.10)';
    for (const c of this.cameras) {
      const heading = Math.atan2(c.look.east, c.look.north);
      const reach = WEDGE_M * f.scale;
      g.beginPath();
      g.moveTo(f.x(c.east), f.y(c.north));
      // Canvas angles run clockwise from +x; a heading clockwise from north.
      g.arc(f.x(c.east), f.y(c.north), reach, heading - Math.PI / 2 - c.fov / 2, heading - Math.PI / 2 + c.fov / 2);
      g.closePath();
      g.fill();
    }
    g.restore();
  }

  drawPoints(g, f) {
    g.fillStyle = 'rgba(220, 220, 220, 0.55)';
    for (let i = 0; i < this.points.length; i += 2) {
      g.fillRect(f.x(this.points[i]) - 0.5, f.y(this.points[i + 1]) - 0.5, 1.2, 1.2);
    }
  }

  drawCameras(g, f) {
    for (const c of this.cameras) {
      const x = f.x(c.east), y = f.y(c.north);
      const len = Math.hypot(c.look.east, c.look.north) || 1;
      g.strokeStyle = g.fillStyle = scoutColour(c.scout);
      g.beginPath();
      g.arc(x, y, 3, 0, 2 * Math.PI);
      g.fill();
      g.beginPath();
      g.moveTo(x, y);
      g.lineTo(x + (9 * c.look.east) / len, y - (9 * c.look.north) / len);
      g.stroke();
    }
  }

  drawSelf(g, f) {
    if (!this.self) return;
    const x = f.x(this.self.east), y = f.y(this.self.north);
    g.strokeStyle = 'rgba(80, 170, 255, 0.8)';
    g.fillStyle = 'rgba(80, 170, 255, 0.15)';
    g.beginPath();
    g.arc(x, y, Math.max(4, (this.self.accuracy || 0) * f.scale), 0, 2 * Math.PI);
    g.fill();
    g.stroke();
    g.fillStyle = '#4aa8ff';
    g.beginPath();
    if (Number.isFinite(this.self.heading)) {
      const a = (this.self.heading * Math.PI) / 180;
      const tip = [x + 12 * Math.sin(a), y - 12 * Math.cos(a)];
      g.moveTo(...tip);
      g.lineTo(x + 6 * Math.sin(a + 2.4), y - 6 * Math.cos(a + 2.4));
      g.lineTo(x + 6 * Math.sin(a - 2.4), y - 6 * Math.cos(a - 2.4));
      g.closePath();
    } else {
      g.arc(x, y, 6, 0, 2 * Math.PI);
    }
    g.fill();
  }

  drawScale(g, f, width, height) {
    const target = width / 4 / f.scale;
    const step = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000].find((s) => s >= target) || 1000;
    const px = step * f.scale;
    g.strokeStyle = g.fillStyle = '#ccc';
    g.beginPath();
    g.moveTo(12, height - 14);
    g.lineTo(12 + px, height - 14);
    g.stroke();
    g.font = '12px system-ui, sans-serif';
    g.fillText(`${step} m`, 12, height - 20);
    g.fillText('N ↑', width - 34, 18);
  }
}
