// A parser for the point clouds the engine writes (docs/engine.md,
// write_points_ply): binary little-endian PLY with one vertex element of
// float x, y, z and uchar red, green, blue, and for fused dense clouds then
// float nx, ny, nz, uchar support and uchar score (clouds written before
// the score end at support). Anything else is refused with a message that
// says what was found.

const EXPECTED = [
  ['x', 'float'],
  ['y', 'float'],
  ['z', 'float'],
  ['red', 'uchar'],
  ['green', 'uchar'],
  ['blue', 'uchar'],
];
const FUSED = [...EXPECTED, ['nx', 'float'], ['ny', 'float'], ['nz', 'float'], ['support', 'uchar']];
const SCORED = [...FUSED, ['score', 'uchar']];
const STRIDE = 3 * 4 + 3;
const FUSED_STRIDE = STRIDE + 3 * 4 + 1;
const SCORED_STRIDE = FUSED_STRIDE + 1;

// PLY names some types two ways.
const TYPE_ALIASES = { float32: 'float', uint8: 'uchar' };

const MAX_HEADER = 64 * 1024;

export class PlyError extends Error {
  constructor(message) {
    super(`PLY: ${message}`);
    this.name = 'PlyError';
  }
}

/** Byte offset just past "end_header\n" (or "\r\n"), or -1. */
function headerEnd(bytes) {
  const marker = 'end_header';
  const limit = Math.min(bytes.length, MAX_HEADER);
  outer: for (let i = 0; i + marker.length < limit; i++) {
    for (let k = 0; k < marker.length; k++) {
      if (bytes[i + k] !== marker.charCodeAt(k)) continue outer;
    }
    // Must start a line.
    if (i > 0 && bytes[i - 1] !== 0x0a) continue;
    let end = i + marker.length;
    if (bytes[end] === 0x0d) end++;
    if (bytes[end] !== 0x0a) continue;
    return end + 1;
  }
  return -1;
}

function parseHeader(text) {
  const lines = text.split(/\r?\n/).map((l) => l.trim()).filter((l) => l.length > 0);
  if (lines[0] !== 'ply') throw new PlyError('not a PLY file (no "ply" magic line)');
  let format = '';
  const elements = [];
  for (const line of lines.slice(1)) {
    const words = line.split(/\s+/);
    switch (words[0]) {
      case 'format':
        format = words[1];
        break;
      case 'element': {
        const count = Number(words[2]);
        if (words.length !== 3 || !Number.isInteger(count) || count < 0) {
          throw new PlyError(`bad element line "${line}"`);
        }
        elements.push({ name: words[1], count, properties: [] });
        break;
      }
      case 'property': {
        const element = elements[elements.length - 1];
        if (!element) throw new PlyError(`property before any element: "${line}"`);
        if (words[1] === 'list') {
          element.properties.push({ name: words[4], type: 'list' });
        } else {
          element.properties.push({ name: words[2], type: TYPE_ALIASES[words[1]] || words[1] });
        }
        break;
      }
      case 'comment':
      case 'obj_info':
      case 'end_header':
        break;
      default:
        throw new PlyError(`unknown header line "${line}"`);
    }
  }
  return { format, elements };
}

function checkLayout({ format, elements }) {
  if (format !== 'binary_little_endian') {
    throw new PlyError(`format "${format || '(none)'}" is not supported, only binary_little_endian`);
  }
  const vertex = elements.find((e) => e.name === 'vertex');
  if (!vertex) throw new PlyError('no "element vertex" in the header');
  // Other elements (faces...) would follow the vertices; only empty ones are harmless.
  const extra = elements.filter((e) => e !== vertex && e.count > 0);
  if (extra.length > 0) {
    throw new PlyError(`element "${extra[0].name}" is not supported (only vertices)`);
  }
  const found = vertex.properties.map((p) => `${p.type} ${p.name}`).join(', ');
  const wanted = EXPECTED.map(([name, type]) => `${type} ${name}`).join(', ');
  const is = (layout) => vertex.properties.length === layout.length &&
    vertex.properties.every((p, i) => p.name === layout[i][0] && p.type === layout[i][1]);
  if (is(EXPECTED)) return { count: vertex.count, stride: STRIDE };
  if (is(FUSED)) return { count: vertex.count, stride: FUSED_STRIDE };
  if (is(SCORED)) return { count: vertex.count, stride: SCORED_STRIDE };
  throw new PlyError(`vertex layout (${found}) is not the supported (${wanted}, optionally then float nx, ny, nz, uchar support[, uchar score])`);
}

/**
 * Parses a point cloud.
 * @param {ArrayBuffer} buffer the whole file
 * @returns {{count: number, positions: Float32Array, colors: Uint8Array, support: Uint8Array, score: Uint8Array}}
 *   positions x,y,z per point, colors r,g,b per point, support and score
 *   per point (0 for a cloud without them)
 */
export function parsePly(buffer) {
  const bytes = new Uint8Array(buffer);
  const start = headerEnd(bytes);
  if (start < 0) {
    const magic = new TextDecoder().decode(bytes.subarray(0, 3));
    throw new PlyError(magic === 'ply' ? 'no end_header line' : 'not a PLY file');
  }
  const header = parseHeader(new TextDecoder('latin1').decode(bytes.subarray(0, start)));
  const { count, stride } = checkLayout(header);
  const needed = start + count * stride;
  if (bytes.length < needed) {
    throw new PlyError(`truncated: ${count} vertices need ${needed} bytes, the file has ${bytes.length}`);
  }

  const positions = new Float32Array(count * 3);
  const colors = new Uint8Array(count * 3);
  const view = new DataView(buffer, 0, needed);
  const support = new Uint8Array(count);
  const score = new Uint8Array(count);
  for (let i = 0, at = start; i < count; i++, at += stride) {
    const p = i * 3;
    positions[p] = view.getFloat32(at, true);
    positions[p + 1] = view.getFloat32(at + 4, true);
    positions[p + 2] = view.getFloat32(at + 8, true);
    colors[p] = bytes[at + 12];
    colors[p + 1] = bytes[at + 13];
    colors[p + 2] = bytes[at + 14];
    if (stride >= FUSED_STRIDE) support[i] = bytes[at + 27];
    if (stride === SCORED_STRIDE) score[i] = bytes[at + 28];
  }
  return { count, positions, colors, support, score };
}
