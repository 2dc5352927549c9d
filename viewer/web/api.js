// HTTP access to the arscout API (docs/api.md): the bearer token, JSON
// calls, authenticated binary downloads with progress, and file downloads.

const TOKEN_KEY = 'arscout.token';

/** The token was missing or rejected (HTTP 401). */
export class UnauthorizedError extends Error {
  constructor(message = 'the server rejected the token') {
    super(message);
    this.name = 'UnauthorizedError';
  }
}

/** Any other non-2xx answer; `status` and `kind` come from the error body. */
export class ApiError extends Error {
  constructor(status, kind, message) {
    super(message || `HTTP ${status}`);
    this.name = 'ApiError';
    this.status = status;
    this.kind = kind;
  }
}

/** The planner token, kept in sessionStorage for the tab's lifetime. */
export const tokenStore = {
  get() {
    return sessionStorage.getItem(TOKEN_KEY) || '';
  },
  set(token) {
    sessionStorage.setItem(TOKEN_KEY, token);
  },
  clear() {
    sessionStorage.removeItem(TOKEN_KEY);
  },
};

/** Encodes each segment of a store path ("sites/a b/model") for a URL. */
export function encodePath(path) {
  return path.split('/').map(encodeURIComponent).join('/');
}

async function errorFrom(response) {
  let kind = '';
  let message = `${response.status} ${response.statusText}`.trim();
  try {
    const body = await response.json();
    if (body && typeof body === 'object') {
      kind = body.error || '';
      if (body.message) message = body.message;
    }
  } catch {
    // not JSON: keep the status line
  }
  return new ApiError(response.status, kind, message);
}

export class ApiClient {
  /**
   * @param {object} options
   * @param {() => void} options.onUnauthorized called on every 401
   * @param {{get: () => string}} [options.tokens] where the token is kept
   *   (the viewer's tab-long tokenStore unless given)
   */
  constructor({ onUnauthorized, tokens = tokenStore }) {
    this.onUnauthorized = onUnauthorized;
    this.tokens = tokens;
  }

  get token() {
    return this.tokens.get();
  }

  /** fetch() with the bearer token; throws on 401 and on other errors. */
  async request(url, init = {}) {
    const token = this.token;
    if (!token) {
      this.onUnauthorized();
      throw new UnauthorizedError('no token');
    }
    const headers = new Headers(init.headers || {});
    headers.set('Authorization', `Bearer ${token}`);
    const response = await fetch(url, { ...init, headers });
    if (response.status === 401) {
      this.onUnauthorized();
      throw new UnauthorizedError();
    }
    if (!response.ok) throw await errorFrom(response);
    return response;
  }

  async json(url, init) {
    const response = await this.request(url, init);
    return response.json();
  }

  /** The JSON document at a store path, or null when it does not exist. */
  async doc(path) {
    try {
      return await this.json(`/v1/docs/${encodePath(path)}`);
    } catch (err) {
      if (err instanceof ApiError && err.status === 404) return null;
      throw err;
    }
  }

  /** Every site, or those within `radius` metres of `near` ({lat, lon}). */
  async sites(near, radius = 1000) {
    const query = near ? `?near=${near.lat.toFixed(7)},${near.lon.toFixed(7)}&radius=${radius}` : '';
    const body = await this.json(`/v1/sites${query}`);
    return body.sites || [];
  }

  /** The capture documents the engine has placed in `site`. */
  async captures(site) {
    const body = await this.json(`/v1/sites/${encodeURIComponent(site)}/captures`);
    return body.captures || [];
  }

  /** A Blob of an authenticated resource (thumbnails, overlays). */
  async blob(url) {
    const response = await this.request(url);
    return response.blob();
  }

  /**
   * Downloads a resource as an ArrayBuffer, reading the body as a stream.
   * @param {string} url
   * @param {(received: number, total: number) => void} onProgress total is
   *   0 when the server sent no Content-Length
   * @param {AbortSignal} [signal]
   */
  async download(url, onProgress, signal) {
    const response = await this.request(url, { signal });
    const total = Number(response.headers.get('Content-Length')) || 0;
    if (!response.body || !response.body.getReader) {
      const buffer = await response.arrayBuffer();
      onProgress(buffer.byteLength, buffer.byteLength);
      return buffer;
    }
    const reader = response.body.getReader();
    const chunks = [];
    let received = 0;
    onProgress(0, total);
    for (;;) {
      const { done, value } = await reader.read();
      if (done) break;
      chunks.push(value);
      received += value.byteLength;
      onProgress(received, total);
    }
    const bytes = new Uint8Array(received);
    let offset = 0;
    for (const chunk of chunks) {
      bytes.set(chunk, offset);
      offset += chunk.byteLength;
    }
    return bytes.buffer;
  }

  /**
   * Fetches a file and hands it to the browser as a download, named as the
   * server's Content-Disposition says, else `baseName` plus an extension
   * from the Content-Type (else `defaultExtension`).
   */
  async saveAs(url, baseName, defaultExtension = '') {
    const response = await this.request(url);
    const type = (response.headers.get('Content-Type') || '').split(';')[0].trim();
    const name = filenameFrom(response.headers.get('Content-Disposition')) ||
      baseName + (EXTENSIONS[type] ?? defaultExtension);
    const blob = await response.blob();
    const href = URL.createObjectURL(blob);
    const link = document.createElement('a');
    link.href = href;
    link.download = name;
    link.hidden = true;
    document.body.append(link);
    link.click();
    link.remove();
    // Give the browser a moment to start the download before revoking.
    setTimeout(() => URL.revokeObjectURL(href), 10000);
    return name;
  }
}

const EXTENSIONS = {
  'application/zip': '.zip',
  'application/x-tar': '.tar',
  'application/gzip': '.tar.gz',
  'text/csv': '.csv',
  'application/x-ply': '.ply',
  'application/json': '.json',
};

function filenameFrom(disposition) {
  if (!disposition) return '';
  const star = /filename\*\s*=\s*[^']*'[^']*'([^;]+)/i.exec(disposition);
  if (star) {
    try {
      return decodeURIComponent(star[1].trim());
    } catch {
      // fall through to the plain form
    }
  }
  const plain = /filename\s*=\s*"?([^";]+)"?/i.exec(disposition);
  return plain ? plain[1].trim() : '';
}

/** GET /healthz (no token): the store's last sequence number. */
export async function healthz() {
  const response = await fetch('/healthz', { cache: 'no-store' });
  if (!response.ok) throw new ApiError(response.status, 'unavailable', `healthz: HTTP ${response.status}`);
  return response.json();
}
