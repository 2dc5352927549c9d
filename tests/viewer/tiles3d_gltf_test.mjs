#!/usr/bin/env node
// Every tile of a 3D Tiles tileset through the Khronos glTF Validator
// (npm gltf-validator, the official validator compiled to JS; it checks
// the glTF JSON against the glTF 2.0 schema and the binary data against
// the accessors). The tileset must reference each file under tiles/ once
// and every reference must exist; the tiles must give no error and no
// warning, and their vertices must add up to the ECEF PLY's point count
// (additive refinement: each point in exactly one tile).
// tiles3d_gltf_test.sh runs it on the fountain site's exports.
//   node tiles3d_gltf_test.mjs TILESET_DIR ECEF_PLY
//
// Uses gltf-validator from viewer/web/node_modules (npm ci --prefix viewer/web).

import fs from 'node:fs';
import path from 'node:path';
import { requireFromViewer } from './harness.mjs';

const validator = requireFromViewer('gltf-validator');

const [tilesetDir, ecefPly] = process.argv.slice(2);
if (!tilesetDir || !ecefPly) {
  console.error('usage: node tiles3d_gltf_test.mjs TILESET_DIR ECEF_PLY');
  process.exit(2);
}

const failures = [];

function contentUris(tile, out = []) {
  if (tile.content) out.push(tile.content.uri);
  for (const child of tile.children || []) contentUris(child, out);
  return out;
}

// The vertex count from a PLY header ("element vertex N").
function plyVertexCount(file) {
  const fd = fs.openSync(file, 'r');
  const head = Buffer.alloc(4096);
  const n = fs.readSync(fd, head, 0, head.length, 0);
  fs.closeSync(fd);
  const match = /^element vertex (\d+)$/m.exec(head.toString('latin1', 0, n));
  if (!match) throw new Error(`${file}: no "element vertex" line`);
  return Number(match[1]);
}

async function main() {
  const tileset = JSON.parse(fs.readFileSync(path.join(tilesetDir, 'tileset.json'), 'utf8'));
  const uris = contentUris(tileset.root);
  const onDisk = fs.readdirSync(path.join(tilesetDir, 'tiles')).map((name) => `tiles/${name}`);
  const unreferenced = onDisk.filter((name) => !uris.includes(name));
  if (unreferenced.length) failures.push(`files no tile refers to: ${unreferenced.join(', ')}`);
  if (new Set(uris).size !== uris.length) failures.push('a tile content is referenced twice');
  console.log(`glTF Validator ${validator.version()}: ${uris.length} tiles of ${tilesetDir}`);

  const totals = { errors: 0, warnings: 0, infos: 0, hints: 0, vertices: 0 };
  const codes = new Map();
  for (const uri of uris) {
    const file = path.join(tilesetDir, uri);
    if (!fs.existsSync(file)) {
      failures.push(`${uri}: referenced but not in the zip`);
      continue;
    }
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri,
      format: 'glb',
      maxIssues: 0,
      writeTimestamp: false,
    });
    const { issues, info } = report;
    totals.errors += issues.numErrors;
    totals.warnings += issues.numWarnings;
    totals.infos += issues.numInfos;
    totals.hints += issues.numHints;
    totals.vertices += info.totalVertexCount || 0;
    for (const message of issues.messages) {
      const key = `severity ${message.severity} ${message.code}`;
      if (!codes.has(key)) codes.set(key, `${uri} ${message.pointer || ''}: ${message.message}`);
    }
    if (issues.numErrors || issues.numWarnings) {
      failures.push(`${uri}: ${issues.numErrors} errors, ${issues.numWarnings} warnings`);
    }
  }
  console.log(`issues: ${totals.errors} errors, ${totals.warnings} warnings, ` +
              `${totals.infos} infos, ${totals.hints} hints`);
  // Severity 0 error, 1 warning, 2 info, 3 hint: one example of each code.
  for (const [key, example] of codes) console.log(`  ${key}, e.g. ${example}`);

  const expected = plyVertexCount(ecefPly);
  console.log(`vertices in the tiles: ${totals.vertices}; points in the ECEF PLY: ${expected}`);
  if (totals.vertices !== expected) {
    failures.push(`the tiles hold ${totals.vertices} vertices, the ECEF PLY ${expected} points`);
  }

  if (failures.length) {
    for (const failure of failures) console.log(`FAIL: ${failure}`);
    process.exit(1);
  }
  console.log(`PASS: ${uris.length} glb tiles valid glTF 2.0, ${totals.vertices} points`);
}

main().catch((error) => {
  console.log(`FAIL: ${error.stack || error}`);
  process.exit(1);
});
