// The scout app's service worker: the app's own files are kept in a cache
// so the app opens and takes photos without a connection. They are served
// from the cache at once and refreshed from the server behind it
// (stale-while-revalidate), so a new version arrives on the next start.
// The API (/v1/, /healthz) is never cached: photos wait in IndexedDB
// (store.js), not here.

const CACHE = 'arscout-scout-v4';
const SHELL = [
  './',
  'index.html',
  'scout.css',
  'app.js',
  'camera.js',
  'feedback.js',
  'position.js',
  'sign_in.js',
  'site_map.js',
  'store.js',
  'uploader.js',
  'manifest.webmanifest',
  'icons/icon-192.png',
  'icons/icon-512.png',
  '../api.js',
  '../capture_status.js',
  '../live.js',
  '../ply.js',
  '../util.js',
];

self.addEventListener('install', (event) => {
  event.waitUntil(
    caches.open(CACHE).then((cache) => cache.addAll(SHELL)).then(() => self.skipWaiting()),
  );
});

self.addEventListener('activate', (event) => {
  event.waitUntil(
    caches.keys()
      .then((names) => Promise.all(names.filter((n) => n !== CACHE).map((n) => caches.delete(n))))
      .then(() => self.clients.claim()),
  );
});

function isApi(url) {
  return url.pathname.startsWith('/v1/') || url.pathname === '/healthz' || url.pathname === '/metrics';
}

self.addEventListener('fetch', (event) => {
  const url = new URL(event.request.url);
  if (event.request.method !== 'GET' || url.origin !== self.location.origin || isApi(url)) return;
  event.respondWith(
    caches.open(CACHE).then(async (cache) => {
      const cached = await cache.match(event.request, { ignoreSearch: true });
      const fresh = fetch(event.request)
        .then((response) => {
          if (response.ok) cache.put(event.request, response.clone());
          return response;
        })
        .catch(() => cached || Response.error());
      if (cached) {
        event.waitUntil(fresh.then(() => undefined));
        return cached;
      }
      return fresh;
    }),
  );
});
