// Sends the queued photos to POST /v1/captures, one at a time, oldest first.
//
// A photo leaves the queue when the server has stored it (201, or 200 with
// Idempotent-Replay for a repeat) or has refused it for good (4xx other
// than 401/403/408/429: the server's message is kept for the scout). On a
// lost connection or a 5xx/429 the same photo is sent again after a delay
// that doubles up to 30 s, or at once when the browser reports it is back
// online or the app comes back to the foreground. A 401 or 403 stops the
// queue with a message and keeps every photo on the phone until the scout
// gives a new token.

import { ApiError } from '../api.js';
import { CaptureStatus } from '../capture_status.js';

/** What a scout reads when the server stops accepting the token. */
export const TOKEN_REJECTED =
  'the server no longer accepts this token: enter a new one; your photos stay on this phone';

const MIN_DELAY_MS = 1000;
const MAX_DELAY_MS = 30000;

/** Statuses after which a retry can succeed; all other 4xx are final. */
function retryable(status) {
  return status === 408 || status === 429 || status >= 500;
}

async function errorBody(response) {
  try {
    const body = await response.json();
    return { kind: body.error || '', message: body.message || `HTTP ${response.status}` };
  } catch {
    return { kind: '', message: `HTTP ${response.status}` };
  }
}

export class Uploader {
  /**
   * @param {object} options
   * @param {import('./store.js').PhotoStore} options.store
   * @param {() => string} options.token
   * @param {(captureId: string) => Promise<string>} options.prepare makes
   *   sure what the photo refers to exists (its camera document); returns
   *   nothing or throws like a request
   * @param {(record: object) => void} options.onChange a record changed
   * @param {(message: string) => void} options.onStopped the queue stopped
   */
  constructor({ store, token, prepare, onChange, onStopped }) {
    this.store = store;
    this.token = token;
    this.prepare = prepare;
    this.onChange = onChange;
    this.onStopped = onStopped;
    this.running = false;
    this.stopped = '';
    this.delay = MIN_DELAY_MS;
    this.timer = 0;
    this.wake = null;
    window.addEventListener('online', () => this.kick());
    document.addEventListener('visibilitychange', () => {
      if (document.visibilityState === 'visible') this.kick();
    });
  }

  /** Starts sending, or cuts a back-off short. */
  kick() {
    if (this.stopped) return;
    if (this.wake) {
      this.delay = MIN_DELAY_MS;
      this.wake();
      return;
    }
    if (!this.running) this.run();
  }

  /** Stops the queue (the token was rejected elsewhere); photos stay. */
  halt(message) {
    this.stopped = message;
    if (this.wake) this.wake();
  }

  /** Lets a stopped queue (a rejected token) go again. */
  resume() {
    this.stopped = '';
    this.kick();
  }

  async next() {
    const photos = await this.store.all();
    return photos.find((p) => p.state === 'waiting' || p.state === 'sending') || null;
  }

  async run() {
    this.running = true;
    try {
      // Without a token (none given yet) nothing is sent: photos wait.
      for (let photo = await this.next(); photo && !this.stopped && this.token(); photo = await this.next()) {
        const outcome = await this.send(photo);
        if (outcome === 'retry') await this.backOff();
        else this.delay = MIN_DELAY_MS;
      }
    } finally {
      this.running = false;
    }
  }

  backOff() {
    const wait = this.delay * (0.8 + 0.4 * Math.random());
    this.delay = Math.min(this.delay * 2, MAX_DELAY_MS);
    return new Promise((resolve) => {
      this.wake = () => {
        clearTimeout(this.timer);
        this.wake = null;
        resolve();
      };
      this.timer = setTimeout(this.wake, wait);
    });
  }

  async update(photo, changes) {
    const record = await this.store.update(photo.captureId, changes);
    if (record) this.onChange(record);
    return record;
  }

  /** One attempt: 'sent', 'refused', 'retry' or 'stopped'. */
  async send(photo) {
    await this.update(photo, { state: 'sending', attempts: photo.attempts + 1 });
    let response;
    try {
      await this.prepare(photo);
      const form = new FormData();
      form.append('metadata', JSON.stringify(photo.metadata));
      form.append('image', photo.blob, photo.metadata.filename);
      response = await fetch('/v1/captures', {
        method: 'POST',
        headers: { Authorization: `Bearer ${this.token()}` },
        body: form,
      });
    } catch (err) {
      return this.failed(photo, err);
    }
    if (response.status === 200 || response.status === 201) {
      const doc = await response.json().catch(() => ({}));
      const attrs = doc.attrs || {};
      await this.update(photo, {
        state: 'sent', blob: null, error: '', status: attrs.status || CaptureStatus.STORED,
        reason: attrs.status_reason || '', site: attrs.site || '',
        // The server keeps the id under the scout's name (docs/api.md).
        serverId: (doc.path || '').replace(/^\/captures\//, '') || photo.captureId,
      });
      return 'sent';
    }
    const { message } = await errorBody(response);
    return this.failed(photo, new ApiError(response.status, '', message));
  }

  async failed(photo, err) {
    const status = err instanceof ApiError ? err.status : 0;
    if (status === 401 || status === 403) {
      this.stopped = status === 401 ? TOKEN_REJECTED
        : `this token may not upload photos (${err.message}); your photos stay on this phone`;
      await this.update(photo, { state: 'waiting', error: this.stopped });
      this.onStopped(this.stopped);
      return 'stopped';
    }
    if (status && !retryable(status)) {
      await this.update(photo, { state: 'refused', blob: null, error: err.message });
      return 'refused';
    }
    const why = status ? `server busy (${err.message})` : 'no connection';
    await this.update(photo, { state: 'waiting', error: `${why}: will retry` });
    return 'retry';
  }
}
