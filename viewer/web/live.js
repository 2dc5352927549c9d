// The change feed over a WebSocket (GET /v1/subscribe): one JSON change per
// text frame. Reconnects with a growing delay and resumes after the last
// sequence number received, so no change is missed or seen twice.

const MIN_DELAY_MS = 1000;
const MAX_DELAY_MS = 30000;
// A connection that stayed up this long resets the delay.
const STABLE_MS = 10000;

export class LiveFeed {
  /**
   * @param {object} options
   * @param {() => string} options.token the current token
   * @param {(change: object) => void} options.onChange
   * @param {(state: 'connecting'|'live'|'reconnecting'|'offline', detail?: string) => void} options.onState
   * @param {string} [options.pattern] the paths to follow
   */
  constructor({ token, onChange, onState, pattern = '/**' }) {
    this.token = token;
    this.onChange = onChange;
    this.onState = onState;
    this.pattern = pattern;
    this.socket = null;
    this.since = 0;
    this.delay = MIN_DELAY_MS;
    this.retryTimer = 0;
    this.running = false;
    this.openedAt = 0;
  }

  /** Starts following the feed after sequence number `since`. */
  start(since) {
    this.stop();
    this.since = Math.max(this.since, since);
    this.running = true;
    this.delay = MIN_DELAY_MS;
    this.connect('connecting');
  }

  stop() {
    this.running = false;
    clearTimeout(this.retryTimer);
    if (this.socket) {
      const socket = this.socket;
      this.socket = null;
      socket.onopen = socket.onmessage = socket.onclose = socket.onerror = null;
      socket.close();
    }
    this.onState('offline');
  }

  /**
   * Reconnects at once, cutting a back-off short (the network came back,
   * the app came to the foreground); a connection that is open stays.
   */
  reconnectNow() {
    if (!this.running) return;
    if (this.socket && this.socket.readyState <= WebSocket.OPEN) return;
    clearTimeout(this.retryTimer);
    this.delay = MIN_DELAY_MS;
    this.connect('reconnecting');
  }

  url() {
    const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
    const query = new URLSearchParams({
      since: String(this.since),
      pattern: this.pattern,
      access_token: this.token(),
    });
    return `${scheme}//${location.host}/v1/subscribe?${query}`;
  }

  connect(state) {
    this.onState(state);
    const socket = new WebSocket(this.url());
    this.socket = socket;
    socket.onopen = () => {
      this.openedAt = Date.now();
      this.onState('live');
    };
    socket.onmessage = (event) => this.receive(event.data);
    socket.onclose = () => {
      if (this.socket !== socket) return;
      this.socket = null;
      this.scheduleReconnect();
    };
    // An error is always followed by close; the reconnect happens there.
    socket.onerror = () => {};
  }

  receive(data) {
    if (typeof data !== 'string') return;
    let change;
    try {
      change = JSON.parse(data);
    } catch {
      return;
    }
    if (!change || typeof change.seq !== 'number') return;
    if (change.seq <= this.since) return;
    this.since = change.seq;
    this.onChange(change);
  }

  scheduleReconnect() {
    if (!this.running) return;
    if (this.openedAt && Date.now() - this.openedAt > STABLE_MS) this.delay = MIN_DELAY_MS;
    this.openedAt = 0;
    const wait = this.delay;
    this.delay = Math.min(this.delay * 2, MAX_DELAY_MS);
    this.onState('reconnecting', `retry in ${Math.round(wait / 1000)} s`);
    this.retryTimer = setTimeout(() => {
      if (this.running) this.connect('reconnecting');
    }, wait);
  }
}
