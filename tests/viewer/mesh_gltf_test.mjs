#!/usr/bin/env node
// Textured mesh GLBs through the Khronos glTF Validator (npm
// gltf-validator): the mesh layer's stored levels (engine::encode_glb), the
// glb export and the 3dtiles-mesh export's tiles (mesh_export_test.sh).
// Each file must give no error and no warning, hold triangles with
// TEXCOORD_0 and an embedded JPEG, and name KHR_materials_unlit.
//   node mesh_gltf_test.mjs FILE_OR_FOLDER...
// A folder stands for every .glb under it.
//
// Uses gltf-validator from viewer/web/node_modules (npm ci --prefix viewer/web).

import fs from 'node:fs';
import path from 'node:path';
import { requireFromViewer } from './harness.mjs';

const validator = requireFromViewer('gltf-validator');

function glbFiles(where) {
  if (!fs.statSync(where).isDirectory()) return [where];
  return fs.readdirSync(where, { withFileTypes: true }).flatMap((entry) => {
    const full = path.join(where, entry.name);
    if (entry.isDirectory()) return glbFiles(full);
    return entry.name.endsWith('.glb') ? [full] : [];
  });
}

async function main() {
  const files = process.argv.slice(2).flatMap(glbFiles).sort();
  if (!files.length) {
    console.error('usage: node mesh_gltf_test.mjs FILE_OR_FOLDER...');
    process.exit(2);
  }
  console.log(`glTF Validator ${validator.version()}: ${files.length} GLB files`);
  const failures = [];
  const codes = new Map();
  let triangles = 0;
  for (const file of files) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const { issues, info } = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      format: 'glb',
      maxIssues: 0,
      writeTimestamp: false,
    });
    for (const message of issues.messages) {
      const key = `severity ${message.severity} ${message.code}`;
      if (!codes.has(key)) codes.set(key, `${file} ${message.pointer || ''}: ${message.message}`);
    }
    if (issues.numErrors || issues.numWarnings) {
      failures.push(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings`);
    }
    const used = info.extensionsUsed || [];
    if (!used.includes('KHR_materials_unlit')) failures.push(`${file}: KHR_materials_unlit not used`);
    const images = (info.resources || []).filter((r) => r.pointer.startsWith('/images/'));
    if (!images.length || !images.every((r) => r.mimeType === 'image/jpeg' && r.storage === 'buffer-view')) {
      failures.push(`${file}: the atlas is not an embedded JPEG (${JSON.stringify(images)})`);
    }
    if (!info.hasTextures) failures.push(`${file}: no texture`);
    if (!(info.drawCallCount > 0) || !(info.totalTriangleCount > 0)) failures.push(`${file}: no triangles`);
    triangles += info.totalTriangleCount || 0;
  }
  // Severity 0 error, 1 warning, 2 info, 3 hint: one example of each code.
  for (const [key, example] of codes) console.log(`  ${key}, e.g. ${example}`);
  if (failures.length) {
    for (const failure of failures) console.log(`FAIL: ${failure}`);
    process.exit(1);
  }
  console.log(`PASS: ${files.length} GLB files valid glTF 2.0, no errors or warnings, ` +
              `${triangles} triangles, textured and unlit`);
}

main().catch((error) => {
  console.log(`FAIL: ${error.stack || error}`);
  process.exit(1);
});
