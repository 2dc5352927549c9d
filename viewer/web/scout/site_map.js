// A small top-down map of the site, north up: the sparse points, every
// scout's cameras (a colour per scout, each with its viewing wedge), the
// site's coverage (GET /v1/sites/{id}/coverage, docs/coverage.md) and the
// scout's own position, accuracy circle and heading.
//
// Coverage: each facade cell is coloured by how many directions it was
// photographed from (red one, orange two, yellow three, green four or
// more), a side nobody photographed is a dashed red line, and the
// suggested shots are numbered arrows, the first one largest.

const WEDGE_M = 12; // how far a wedge reaches, metres
const EARTH_RADIUS_M = 6378137;

// Scouts' colours, far apart in hue and lightness (Okabe and Ito's
// colour-blind-safe set on a dark map), given in order of name.
const SCOUT_PALETTE = ['#e69f00', '#56b4e9', '#f0e442', '#cc79a7', '#009e73', '#ffffff', '#d55e00', '#0072b2'];
// Directions a facade cell was seen from -> its colour.
const DIRECTION_COLOURS = ['#d7301f', '#d7301f', '#fc8d59', '#fdcc8a', '#1a9850'];

/** Each scout's colour (a Map by name): by its place among the names. */
export function scoutColours(scouts) {
  const sorted = [...new Set(scouts)].sort();
  return new Map(sorted.map((name, i) => [name, SCOUT_PALETTE[i % SCOUT_PALETTE.length]]));
}

/** The colour of a facade cell seen from `directions` compass sectors. */
export function directionColour(directions) {
  return DIRECTION_COLOURS[Math.min(directions, DIRECTION_COLOURS.length - 1)];
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
    this.coverage = { cells: [], unseen: [], suggestions: [], cell: 2 };
  }

  /** The coverage GeoJSON (docs/api.md) in the map's metres. */
  setCoverage(geojson) {
    const coverage = { cells: [], unseen: [], suggestions: [], cell: (geojson && geojson.cell_m) || 2 };
    if (!this.origin || !geojson) {
      this.coverage = coverage;
      return;
    }
    const at = ([lon, lat]) => enuOf(this.origin, lat, lon);
    for (const f of geojson.features || []) {
      const p = f.properties || {};
      const c = f.geometry.coordinates;
      if (p.feature === 'cell') {
        const ring = c[0].map(at);
        coverage.cells.push({
          east: (ring[0].east + ring[2].east) / 2, north: (ring[0].north + ring[2].north) / 2,
          directions: p.directions, views: p.views,
        });
      } else if (p.feature === 'unseen_facade') {
        coverage.unseen.push(c.map(at));
      } else if (p.feature === 'suggestion') {
        coverage.suggestions.push({ ...at(c), heading: p.heading_deg, rank: p.rank, reason: p.reason, kind: p.kind });
      }
    }
    coverage.suggestions.sort((a, b) => a.rank - b.rank);
    this.coverage = coverage;
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
    if (!this.cameras.length && !this.self) {
      // Blank says why: nothing to draw yet, and what brings it.
      g.fillStyle = '#9aa4b2';
      g.font = '14px system-ui, sans-serif';
      g.textAlign = 'center';
      const lines = ['No site yet.', 'The map shows your site once a photo is placed,', 'or a site within 200 m of your GPS fix.'];
      lines.forEach((line, i) => g.fillText(line, width / 2, height / 2 + 20 * (i - 1)));
      g.textAlign = 'start';
      return;
    }
    const f = this.frame(width, height);
    this.drawWedges(g, f);
    this.drawCells(g, f);
    this.drawPoints(g, f);
    this.drawUnseen(g, f);
    this.drawCameras(g, f);
    this.drawSuggestions(g, f);
    this.drawSelf(g, f);
    this.drawScale(g, f, width, height);
  }

  drawWedges(g, f) {
    g.save();
    g.globalCompositeOperation = 'lighter';
    g.fillStyle = 'rgba(70, 110, 160, 0.16)';
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

  drawCells(g, f) {
    const side = Math.max(2, this.coverage.cell * f.scale);
    g.save();
    g.globalAlpha = 0.75;
    for (const c of this.coverage.cells) {
      g.fillStyle = directionColour(c.directions);
      g.fillRect(f.x(c.east) - side / 2, f.y(c.north) - side / 2, side, side);
    }
    g.restore();
  }

  drawUnseen(g, f) {
    g.save();
    g.strokeStyle = '#ff3b30';
    g.lineWidth = 4;
    g.setLineDash([8, 5]);
    for (const [a, b] of this.coverage.unseen) {
      g.beginPath();
      g.moveTo(f.x(a.east), f.y(a.north));
      g.lineTo(f.x(b.east), f.y(b.north));
      g.stroke();
    }
    g.restore();
  }

  drawSuggestions(g, f) {
    g.save();
    for (const s of this.coverage.suggestions) {
      const x = f.x(s.east), y = f.y(s.north);
      const a = (s.heading * Math.PI) / 180;
      const size = s.rank === 1 ? 16 : 11;
      g.fillStyle = s.rank === 1 ? '#ffffff' : 'rgba(255, 255, 255, 0.7)';
      g.strokeStyle = '#000';
      g.beginPath();
      g.moveTo(x + size * Math.sin(a), y - size * Math.cos(a));
      g.lineTo(x + (size / 2) * Math.sin(a + 2.5), y - (size / 2) * Math.cos(a + 2.5));
      g.lineTo(x + (size / 2) * Math.sin(a - 2.5), y - (size / 2) * Math.cos(a - 2.5));
      g.closePath();
      g.fill();
      g.stroke();
      g.font = 'bold 12px system-ui, sans-serif';
      g.fillText(String(s.rank), x - size * Math.sin(a) - 4, y + size * Math.cos(a) + 4);
    }
    g.restore();
  }

  drawCameras(g, f) {
    const colours = scoutColours(this.scouts);
    for (const c of this.cameras) {
      const x = f.x(c.east), y = f.y(c.north);
      const len = Math.hypot(c.look.east, c.look.north) || 1;
      g.strokeStyle = g.fillStyle = colours.get(c.scout);
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
