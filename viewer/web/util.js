// Small helpers shared by the viewer's modules.

/** Calls fn once, `ms` after the last of a burst of calls. */
export function debounce(fn, ms) {
  let timer = 0;
  const debounced = () => {
    clearTimeout(timer);
    timer = setTimeout(fn, ms);
  };
  debounced.cancel = () => clearTimeout(timer);
  return debounced;
}

/**
 * Wraps an async task so that it never runs twice at once: a trigger while
 * it runs makes it run once more afterwards (however many triggers came).
 * The returned function resolves when the run that covers the trigger ends.
 */
export function serialized(task) {
  let running = null;
  let again = false;
  const trigger = () => {
    if (running) {
      again = true;
      return running;
    }
    running = (async () => {
      try {
        do {
          again = false;
          await task();
        } while (again);
      } finally {
        running = null;
      }
    })();
    return running;
  };
  return trigger;
}

/** Runs async jobs with at most `limit` in flight. */
export function limiter(limit) {
  let active = 0;
  const queue = [];
  const next = () => {
    if (active >= limit || queue.length === 0) return;
    active++;
    const { job, resolve, reject } = queue.shift();
    job().then(resolve, reject).finally(() => {
      active--;
      next();
    });
  };
  return (job) => new Promise((resolve, reject) => {
    queue.push({ job, resolve, reject });
    next();
  });
}

export function formatCount(n) {
  return Number(n || 0).toLocaleString('en-US');
}

export function formatBytes(n) {
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(0)} KiB`;
  return `${(n / (1024 * 1024)).toFixed(1)} MiB`;
}

const dateFormat = new Intl.DateTimeFormat(undefined, { dateStyle: 'short', timeStyle: 'medium' });

/** An RFC 3339 time in the browser's locale ("" when absent or invalid). */
export function formatTime(rfc3339) {
  if (!rfc3339) return '';
  const date = new Date(rfc3339);
  return Number.isNaN(date.getTime()) ? rfc3339 : dateFormat.format(date);
}

/** "lat, lon" to 6 decimals, or "" without a fix. */
export function formatLatLon(gps) {
  if (!gps || !Number.isFinite(gps.lat) || !Number.isFinite(gps.lon)) return '';
  return `${gps.lat.toFixed(6)}, ${gps.lon.toFixed(6)}`;
}

/** Creates an element with optional class, text and attributes. */
export function el(tag, { className, text, attrs } = {}, children = []) {
  const node = document.createElement(tag);
  if (className) node.className = className;
  if (text !== undefined && text !== null) node.textContent = String(text);
  if (attrs) {
    for (const [key, value] of Object.entries(attrs)) node.setAttribute(key, String(value));
  }
  node.append(...children);
  return node;
}
