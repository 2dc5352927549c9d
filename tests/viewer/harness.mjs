// Shared by the Node test scripts under tests/viewer: packages from the
// viewer's node_modules (viewer/web/package-lock.json), a log line with the
// seconds since start, a failure type that reports without a stack, the
// Chromium flags for WebGL without a GPU, and a static file server for the
// 3D Tiles pages.

import fs from 'node:fs';
import http from 'node:http';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

/** tests/viewer, for the scripts' own files. */
export const here = path.dirname(fileURLToPath(import.meta.url));
/** The web viewer's folder (viewer/web). */
export const webRoot = path.resolve(here, '../../viewer/web');
/** require() resolving from viewer/web, where npm ci put the packages. */
export const requireFromViewer = createRequire(path.join(webRoot, 'package.json'));

const started = Date.now();
export function log(message) {
  const seconds = ((Date.now() - started) / 1000).toFixed(1).padStart(6);
  console.log(`[${seconds}s] ${message}`);
}

/** A check that failed: reported as "FAIL: message", without a stack. */
export class TestFailure extends Error {}
export function fail(message) {
  throw new TestFailure(message);
}

/** The environment, with KEY=VALUE arguments on top. */
export function keyValueSettings() {
  const values = { ...process.env };
  for (const arg of process.argv.slice(2)) {
    const at = arg.indexOf('=');
    if (at > 0) values[arg.slice(0, at)] = arg.slice(at + 1);
  }
  return values;
}

/** WebGL on the CPU (SwiftShader through ANGLE): no GPU on CI. */
export const SOFTWARE_WEBGL_ARGS = [
  '--no-sandbox',
  '--use-gl=angle',
  '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader',
  '--ignore-gpu-blocklist',
];

// A static file server on a free loopback port for the page, the npm
// packages and the tileset. `files` maps a URL path to a file, `folders` a
// URL prefix to a folder; nothing outside those is served.
export function serve(files, folders) {
  const types = {
    '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript',
    '.json': 'application/json', '.glb': 'model/gltf-binary',
  };
  const server = http.createServer((request, response) => {
    const pathname = decodeURIComponent(new URL(request.url, 'http://localhost').pathname);
    let file = files[pathname] || null;
    for (const [prefix, folder] of Object.entries(folders)) {
      if (file || !pathname.startsWith(prefix)) continue;
      const candidate = path.resolve(folder, pathname.slice(prefix.length));
      if (candidate.startsWith(folder + path.sep)) file = candidate;
    }
    if (!file || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      response.writeHead(404, { 'Content-Type': 'text/plain' });
      response.end(`not found: ${pathname}\n`);
      return;
    }
    response.writeHead(200, {
      'Content-Type': types[path.extname(file)] || 'application/octet-stream',
      'Cache-Control': 'no-store',
    });
    fs.createReadStream(file).pipe(response);
  });
  return new Promise((resolve) => {
    server.listen(0, '127.0.0.1', () => resolve(server));
  });
}
