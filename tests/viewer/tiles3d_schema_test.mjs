#!/usr/bin/env node
// A 3D Tiles tileset.json against the official 3D Tiles 1.1 JSON schema
// (the *.schema.json files of the specification, read from
// ../shared/data/3d-tiles-1.1-schema, never copied here) with ajv (npm,
// draft 2020-12), then the rules of the 3D Tiles 1.1 specification that
// the official schema leaves to its prose:
//  - the root tile's refine is required, and a refine is ADD or REPLACE
//    (the schema accepts any string, for extensions to come);
//  - a bounding volume holds a box, a region or a sphere (or an extension),
//    a sphere's radius is not negative, a region's angles are radians in
//    range with west/south/east/north and heights in order (the schema
//    only counts the numbers);
//  - between tiles: a child's geometricError at most its parent's and the
//    tileset's at least the root's, each child's bounding box inside its
//    parent's, every content uri a file of the tileset and every glb
//    referenced exactly once, extensionsRequired within extensionsUsed,
//    group indices in range, transforms affine.
// Until the official files were at hand (2026-11-28) a schema written here
// from the prose stood in for them; it went, and the first two of those
// rules are what it checked that the official one does not.
//
// Also what arscout's export promises (docs/frames.md): version 1.1,
// additive refinement set at the root (a tile without refine inherits
// it; --refine=REPLACE for the mesh export's, docs/mesh.md), one transform (the root's), tiles as axis-aligned boxes in the
// root's frame (half-axes on the diagonal), which is what makes the box
// nesting check a comparison of intervals.
//
// Then the checks are shown able to fail: each of a list of broken copies
// of the tileset (root geometricError dropped, a child's error above its
// parent's, a box sticking out, a missing file, ...) must be rejected.
//   node tiles3d_schema_test.mjs SCHEMA_DIR TILESET_DIR [--check-only] [--refine=REPLACE]
// SCHEMA_DIR: the folder of the official files (tileset.schema.json and
// the files it refers to). --check-only: only check TILESET_DIR (exit 1 if
// it fails), no broken copies; tiles3d_schema_test.sh runs it on broken
// tilesets on disk.
//
// Uses ajv from viewer/web/node_modules (npm ci --prefix viewer/web).

import fs from 'node:fs';
import path from 'node:path';
import { requireFromViewer } from './harness.mjs';

const Ajv2020 = requireFromViewer('ajv/dist/2020.js').default;
const ajvVersion = requireFromViewer('ajv/package.json').version;

const args = process.argv.slice(2);
const checkOnly = args.includes('--check-only');
const refineArg = args.find((arg) => arg.startsWith('--refine='));
const exportRefine = refineArg ? refineArg.slice('--refine='.length) : 'ADD';
const positional = args.filter((arg) => arg !== '--check-only' && arg !== refineArg);
if (positional.length !== 2 || !['ADD', 'REPLACE'].includes(exportRefine)) {
  console.error('usage: node tiles3d_schema_test.mjs SCHEMA_DIR TILESET_DIR [--check-only] [--refine=ADD|REPLACE]');
  process.exit(2);
}
const [schemaDir, tilesetDir] = positional;

// Every file under DIR, as paths relative to it with '/'.
function filesUnder(dir, prefix = '') {
  const out = [];
  for (const entry of fs.readdirSync(path.join(dir, prefix), { withFileTypes: true })) {
    const relative = prefix ? `${prefix}/${entry.name}` : entry.name;
    if (entry.isDirectory()) out.push(...filesUnder(dir, relative));
    else out.push(relative);
  }
  return out;
}

// The official files name themselves by bare file names ("$id":
// "tile.schema.json") and refer to each other by paths relative to their
// own folder ("./common/rootProperty.schema.json"), so each is given its
// path under one base as $id. They are not strict-mode clean (types come
// through $ref), hence strict off. Their two formats are "iri-reference"
// (tileset.schemaUri, buffer.uri), checked as RFC 3987 allows: no spaces,
// controls or the characters it excludes.
const started = process.hrtime.bigint();
const schemaBase = 'https://3d-tiles.invalid/specification/schema/';
const ajv = new Ajv2020({ strict: false, allErrors: true });
ajv.addFormat('iri-reference', /^[^\s<>"{}|\\^`\u0000-\u001f\u007f]*$/u);
const schemaFiles = filesUnder(schemaDir).filter((file) => file.endsWith('.schema.json'));
for (const file of schemaFiles) {
  const schema = JSON.parse(fs.readFileSync(path.join(schemaDir, file), 'utf8'));
  ajv.addSchema({ ...schema, $id: schemaBase + file });
}
const validateSchema = ajv.getSchema(`${schemaBase}tileset.schema.json`);
if (!validateSchema) {
  console.error(`FAIL: no tileset.schema.json in ${schemaDir}`);
  process.exit(1);
}

// box = [centre x y z, x half-axis, y half-axis, z half-axis]: for an
// axis-aligned box the half-axes have only their own component.
function axisAligned(box) {
  return [4, 5, 6, 8, 9, 10].every((i) => box[i] === 0) &&
         [3, 7, 11].every((i) => box[i] >= 0);
}
function interval(box, axis) {
  const half = box[3 + 4 * axis];
  return [box[axis] - half, box[axis] + half];
}
// Slack for rounding when comparing box faces, in metres.
const boxTolerance = 1e-6;
function boxInside(inner, outer) {
  for (let axis = 0; axis < 3; ++axis) {
    const [a, b] = interval(inner, axis);
    const [lo, hi] = interval(outer, axis);
    if (a < lo - boxTolerance || b > hi + boxTolerance) return false;
  }
  return true;
}

// A relative URI resolved against the tileset's folder, or null if it
// is absolute, has a scheme or leaves the folder.
function resolveUri(uri) {
  if (/^[a-zA-Z][a-zA-Z0-9+.-]*:/.test(uri) || uri.startsWith('/')) return null;
  const clean = decodeURIComponent(uri.split(/[?#]/)[0]);
  const resolved = path.posix.normalize(clean);
  if (resolved.startsWith('../') || resolved === '..') return null;
  return resolved;
}

// The prose's rules on one bounding volume (WHERE names it): one of box,
// region or sphere (an extension may define another), a sphere's radius
// not negative, a region's [west, south, east, north] in radians within
// [-pi, pi] and [-pi/2, pi/2], south <= north and minimum height <= maximum
// (west may exceed east: a region across the antimeridian).
function volumeFailures(volume, where) {
  const out = [];
  if (!volume.box && !volume.region && !volume.sphere && !volume.extensions) {
    out.push(`${where}: neither box, region nor sphere`);
  }
  if (volume.sphere && volume.sphere[3] < 0) out.push(`${where}: sphere radius ${volume.sphere[3]} is negative`);
  if (volume.region) {
    const [west, south, east, north, low, high] = volume.region;
    const inRange = (v, limit) => v >= -limit && v <= limit;
    if (![west, east].every((v) => inRange(v, Math.PI)) ||
        ![south, north].every((v) => inRange(v, Math.PI / 2))) {
      out.push(`${where}: region angles outside [-pi, pi] x [-pi/2, pi/2] radians`);
    }
    if (south > north) out.push(`${where}: region south ${south} above north ${north}`);
    if (low > high) out.push(`${where}: region minimum height ${low} above maximum ${high}`);
  }
  return out;
}

// All failures of TILESET (parsed JSON) whose folder holds FILES; STATS,
// if given, receives counts.
function check(tileset, files, stats = {}) {
  if (!validateSchema(tileset)) {
    // The rules below assume the shape the schema checks.
    return validateSchema.errors.map((e) => `schema: ${e.instancePath || '/'} ${e.message}`);
  }
  const failures = [];
  const fail = (message) => failures.push(message);
  const root = tileset.root;

  // Specification rules.
  if (tileset.geometricError < root.geometricError) {
    fail(`tileset geometricError ${tileset.geometricError} is below the root's ${root.geometricError}`);
  }
  const used = tileset.extensionsUsed || [];
  for (const name of tileset.extensionsRequired || []) {
    if (!used.includes(name)) fail(`extension ${name} is required but not in extensionsUsed`);
  }
  const references = new Map();
  let tiles = 0;
  let depth = 0;
  function visit(tile, where, parent, refine, level) {
    ++tiles;
    depth = Math.max(depth, level);
    const effectiveRefine = tile.refine || refine;
    if (!parent && tile.refine === undefined) fail(`${where}: refine is required for the root tile`);
    if (tile.refine !== undefined && tile.refine !== 'ADD' && tile.refine !== 'REPLACE') {
      fail(`${where}: refine "${tile.refine}" is neither ADD nor REPLACE`);
    }
    failures.push(...volumeFailures(tile.boundingVolume, `${where}/boundingVolume`));
    if (tile.viewerRequestVolume) {
      failures.push(...volumeFailures(tile.viewerRequestVolume, `${where}/viewerRequestVolume`));
    }
    if (parent && tile.geometricError > parent.geometricError) {
      fail(`${where}: geometricError ${tile.geometricError} exceeds its parent's ${parent.geometricError}`);
    }
    if (tile.transform) {
      const m = tile.transform;
      if (m[3] !== 0 || m[7] !== 0 || m[11] !== 0 || m[15] !== 1) {
        fail(`${where}: transform is not affine (last row ${m[3]} ${m[7]} ${m[11]} ${m[15]})`);
      }
    }
    const contents = tile.contents || (tile.content ? [tile.content] : []);
    contents.forEach((content, i) => {
      const resolved = resolveUri(content.uri);
      if (resolved === null) {
        fail(`${where}: content uri "${content.uri}" does not name a file of the tileset`);
      } else {
        references.set(resolved, (references.get(resolved) || 0) + 1);
        if (!files.includes(resolved)) fail(`${where}: content "${content.uri}" is not in the zip`);
      }
      if (content.group !== undefined && !(content.group < (tileset.groups || []).length)) {
        fail(`${where}: content ${i} names group ${content.group}, the tileset has ${(tileset.groups || []).length}`);
      }
      if (content.boundingVolume) {
        failures.push(...volumeFailures(content.boundingVolume, `${where}/content/${i}/boundingVolume`));
      }
      const inner = content.boundingVolume && content.boundingVolume.box;
      if (inner && tile.boundingVolume.box && !boxInside(inner, tile.boundingVolume.box)) {
        fail(`${where}: content ${i}'s box is not inside the tile's box`);
      }
    });

    // What arscout's export promises.
    if (effectiveRefine !== exportRefine) {
      fail(`${where}: refine ${effectiveRefine}, the export refines by ${exportRefine}`);
    }
    if (tile.transform && parent) fail(`${where}: a transform below the root (the export has one frame)`);
    const box = tile.boundingVolume.box;
    if (!box) {
      fail(`${where}: no box bounding volume`);
    } else if (!axisAligned(box)) {
      fail(`${where}: box ${JSON.stringify(box)} is not axis-aligned`);
    } else if (parent && parent.boundingVolume.box && !boxInside(box, parent.boundingVolume.box)) {
      fail(`${where}: box ${JSON.stringify(box)} is not inside its parent's ` +
           `${JSON.stringify(parent.boundingVolume.box)}`);
    }

    (tile.children || []).forEach((child, i) => {
      visit(child, `${where}/children/${i}`, tile, effectiveRefine, level + 1);
    });
  }
  visit(root, 'root', null, undefined, 0);
  if (tileset.asset.version !== '1.1') fail(`asset.version ${tileset.asset.version}, the export writes 1.1`);

  for (const [file, count] of references) {
    if (count > 1) fail(`${file} is referenced by ${count} contents`);
  }
  const unreferenced = files.filter((file) => file.endsWith('.glb') && !references.has(file));
  if (unreferenced.length) fail(`glb files no tile refers to: ${unreferenced.join(', ')}`);
  Object.assign(stats, { tiles, depth, contents: references.size });
  return failures;
}

// Broken copies: each mutation must make check() fail with a message
// matching its pattern (so it fails for the intended reason).
function parentWithChildren(tile) {
  if (tile.children && tile.children.some((child) => child.children)) return tile;
  for (const child of tile.children || []) {
    const found = parentWithChildren(child);
    if (found) return found;
  }
  return null;
}
function firstContentTile(tile) {
  if (tile.content) return tile;
  for (const child of tile.children || []) {
    const found = firstContentTile(child);
    if (found) return found;
  }
  return null;
}
const mutations = [
  ['root geometricError dropped', /root must have required property 'geometricError'/,
    (t) => { delete t.root.geometricError; }],
  ['tileset geometricError dropped', /must have required property 'geometricError'/,
    (t) => { delete t.geometricError; }],
  ['a child\'s geometricError above its parent\'s', /\/children\/0: geometricError .* exceeds its parent's/,
    (t) => { const p = parentWithChildren(t.root); p.children[0].geometricError = p.geometricError * 2 + 1; }],
  ['tileset geometricError below the root\'s', /below the root's/,
    (t) => { t.geometricError = t.root.geometricError / 2; }],
  ['root refine dropped', /^root: refine is required for the root tile/,
    (t) => { delete t.root.refine; }],
  ['refine in lower case', /^root: refine "add" is neither ADD nor REPLACE/,
    (t) => { t.root.refine = 'add'; }],
  ['a child\'s refine outside ADD and REPLACE', /children\/0: refine "MERGE" is neither ADD nor REPLACE/,
    (t) => { t.root.children[0].refine = 'MERGE'; }],
  ['a box of 11 numbers', /box must NOT have fewer than 12 items/,
    (t) => { t.root.boundingVolume.box.pop(); }],
  ['a transform of 15 numbers', /transform must NOT have fewer than 16 items/,
    (t) => { t.root.transform.pop(); }],
  ['a negative sphere radius', /^root\/boundingVolume: sphere radius -1 is negative/,
    (t) => { t.root.boundingVolume = { sphere: [0, 0, 0, -1] }; }],
  ['a sphere of 5 numbers', /sphere must NOT have more than 4 items/,
    (t) => { t.root.boundingVolume = { sphere: [0, 0, 0, 1, 2] }; }],
  ['a region with south above north', /^root\/boundingVolume: region south 0.5 above north 0.4/,
    (t) => { t.root.boundingVolume = { region: [0, 0.5, 0.1, 0.4, 0, 10] }; }],
  ['a region in degrees', /^root\/boundingVolume: region angles outside/,
    (t) => { t.root.boundingVolume = { region: [6, 45, 7, 46, 0, 10] }; }],
  ['a bounding volume of extras only', /^root\/boundingVolume: neither box, region nor sphere/,
    (t) => { t.root.boundingVolume = { extras: {} }; }],
  ['a bounding volume that is empty', /boundingVolume must NOT have fewer than 1 properties/,
    (t) => { t.root.boundingVolume = {}; }],
  ['children empty', /children must NOT have fewer than 1 items/,
    (t) => { firstContentTile(t.root.children[0]).children = []; }],
  ['content without uri', /content must have required property 'uri'/,
    (t) => { delete t.root.content.uri; }],
  ['asset without version', /asset must have required property 'version'/,
    (t) => { delete t.asset.version; }],
  ['asset.version a number', /asset\/version must be string/,
    (t) => { t.asset.version = 1.1; }],
  ['asset.version 2.0', /asset.version 2.0, the export writes 1.1/,
    (t) => { t.asset.version = '2.0'; }],
  ['both schema and schemaUri', /^schema: \/ must NOT be valid/,
    (t) => { t.schema = { id: 'arscout' }; t.schemaUri = 'schema.json'; }],
  ['content and contents together', /^schema: \/root must NOT be valid/,
    (t) => { t.root.contents = [{ uri: t.root.content.uri }]; }],
  ['a child\'s box sticking out of its parent\'s', /^root\/children\/0: box .* is not inside its parent's/,
    (t) => { t.root.children[0].boundingVolume.box[0] += 2 * t.root.boundingVolume.box[3]; }],
  ['a content uri with no file', /is not in the zip/,
    (t) => { firstContentTile(t.root.children[0]).content.uri = 'tiles/missing.glb'; }],
  ['a glb no tile refers to', /glb files no tile refers to/,
    (t) => { delete firstContentTile(t.root.children[0]).content; }],
  ['a glb referenced twice', /referenced by 2 contents/,
    (t) => { firstContentTile(t.root.children[0]).content.uri = t.root.content.uri; }],
  ['a content uri leaving the folder', /does not name a file of the tileset/,
    (t) => { t.root.content.uri = '../r.glb'; }],
];

const tileset = JSON.parse(fs.readFileSync(path.join(tilesetDir, 'tileset.json'), 'utf8'));
const files = filesUnder(tilesetDir);
const stats = {};
const failures = check(tileset, files, stats);
console.log(`ajv ${ajvVersion} (draft 2020-12), the official schema (${schemaFiles.length} files in ${schemaDir}): ` +
            `${tilesetDir}/tileset.json, ${stats.tiles ?? '?'} tiles, depth ${stats.depth ?? '?'}, ` +
            `${files.filter((f) => f.endsWith('.glb')).length} glb files`);
for (const failure of failures) console.log(`FAIL: ${failure}`);

let broken = 0;
if (!checkOnly) {
  for (const [name, expected, mutate] of mutations) {
    const copy = structuredClone(tileset);
    mutate(copy);
    const found = check(copy, files);
    if (!found.length) {
      failures.push(`broken copy passed: ${name}`);
      console.log(`FAIL: broken copy "${name}" passed the checks`);
    } else if (!found.some((message) => expected.test(message))) {
      failures.push(`broken copy failed for another reason: ${name}`);
      console.log(`FAIL: broken copy "${name}" failed, but not with ${expected}: ${found.join('; ')}`);
    } else {
      ++broken;
      console.log(`  rejected as expected: ${name} (${found.find((m) => expected.test(m))})`);
    }
  }
}

const ms = Number(process.hrtime.bigint() - started) / 1e6;
if (failures.length) {
  console.log(`FAIL: ${failures.length} problems (${ms.toFixed(0)} ms)`);
  process.exit(1);
}
console.log(`PASS: tileset.json valid against the schema and the specification's tree rules` +
            (checkOnly ? '' : `; ${broken} broken copies all rejected`) + ` (${ms.toFixed(0)} ms)`);
