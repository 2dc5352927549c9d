// Page furniture: the status line, the download progress bar, the token
// dialog, the overlay dialog and the live-feed indicator.

import { formatBytes } from './util.js';

const $ = (id) => document.getElementById(id);

export const status = {
  source: '',
  /**
   * Shows a message; kind "error" stays, "info" fades after a while.
   * `source` names what reported it, so that it can be cleared when that
   * thing works again.
   */
  show(text, kind = 'info', source = '') {
    const line = $('status');
    line.textContent = text;
    line.dataset.kind = kind;
    this.source = source;
    clearTimeout(this.timer);
    if (kind !== 'error' && text) this.timer = setTimeout(() => this.clear(), 8000);
  },
  error(text, source = '') {
    this.show(text, 'error', source);
  },
  /** Clears the line; with a source, only a message from that source. */
  clear(source) {
    if (source !== undefined && source !== this.source) return;
    $('status').textContent = '';
    $('status').dataset.kind = 'info';
    this.source = '';
  },
};

export const progress = {
  /** @param {number} total 0 when unknown */
  show(label, received, total) {
    $('progress').hidden = false;
    const bar = $('progress-bar');
    if (total > 0) {
      const percent = Math.min(100, (100 * received) / total);
      bar.style.width = `${percent.toFixed(1)}%`;
      bar.classList.remove('indeterminate');
      $('progress-text').textContent = `${label} ${percent.toFixed(0)}% (${formatBytes(received)} of ${formatBytes(total)})`;
    } else {
      bar.style.width = '100%';
      bar.classList.add('indeterminate');
      $('progress-text').textContent = `${label} ${formatBytes(received)}`;
    }
  },
  hide() {
    $('progress').hidden = true;
  },
};

/** The centred message over the 3D view ("" hides it). */
export function viewMessage(text) {
  const box = $('view-message');
  box.textContent = text;
  box.hidden = !text;
}

export const tokenDialog = {
  /**
   * Asks for the token; `onToken` gets the trimmed entry.
   * @param {string} message why it is asked for
   */
  open(message, onToken) {
    const dialog = $('token-dialog');
    const form = $('token-form');
    const input = $('token-input');
    $('token-message').textContent = message;
    dialog.hidden = false;
    input.value = '';
    input.focus();
    form.onsubmit = (event) => {
      event.preventDefault();
      const token = input.value.trim();
      if (!token) return;
      dialog.hidden = true;
      form.onsubmit = null;
      onToken(token);
    };
  },
  get isOpen() {
    return !$('token-dialog').hidden;
  },
};

export const overlayDialog = {
  url: '',
  /**
   * Shows an image that `load` fetches (a Promise of a Blob).
   * @param {string} title
   * @param {() => Promise<Blob>} load
   */
  async open(title, load) {
    this.close();
    const image = $('overlay-image');
    $('overlay-title').textContent = title;
    $('overlay-message').textContent = 'loading...';
    image.hidden = true;
    $('overlay-dialog').hidden = false;
    const ticket = (this.ticket = (this.ticket || 0) + 1);
    try {
      const blob = await load();
      if (ticket !== this.ticket) return;
      this.url = URL.createObjectURL(blob);
      image.src = this.url;
      image.hidden = false;
      $('overlay-message').textContent = '';
    } catch (err) {
      if (ticket === this.ticket) $('overlay-message').textContent = `could not load: ${err.message}`;
    }
  },
  close() {
    this.ticket = (this.ticket || 0) + 1;
    $('overlay-dialog').hidden = true;
    $('overlay-image').removeAttribute('src');
    if (this.url) URL.revokeObjectURL(this.url);
    this.url = '';
  },
  init() {
    $('overlay-close').addEventListener('click', () => this.close());
    $('overlay-dialog').addEventListener('click', (event) => {
      if (event.target === $('overlay-dialog')) this.close();
    });
    document.addEventListener('keydown', (event) => {
      if (event.key === 'Escape' && !$('overlay-dialog').hidden) this.close();
    });
  },
};

const LIVE_LABELS = {
  connecting: 'connecting...',
  live: 'live',
  reconnecting: 'reconnecting',
  offline: 'offline',
};

export function showLiveState(state, detail = '') {
  const badge = $('live-state');
  badge.dataset.state = state;
  badge.textContent = LIVE_LABELS[state] || state;
  badge.title = detail ? `change feed: ${detail}` : 'change feed';
}
