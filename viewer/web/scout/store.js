// The scout's photos on the phone: an IndexedDB store that outlives reloads,
// lost connections and the browser being killed in the background.
//
// Every photo is written here before anything is sent. Its capture id is
// the device's id and a counter taken in the same transaction as the
// photo's record, so an id is never handed out twice and a retry after
// any failure sends the same id again: the server answers a repeat with
// the first result (docs/api.md, idempotency), so nothing is stored twice.
//
// A photo record:
//   { captureId, seq, blob (JPEG), width, height, metadata (what is sent),
//     state: 'waiting' | 'sending' | 'sent' | 'refused' | 'withdrawn',
//     attempts, error (the last failure, words), takenAt (ms),
//     serverId (the id the server stored it under, "{scout}.{captureId}"),
//     status (the engine's: stored, needs-gps, registered, rejected, ...),
//     reason, site, modelVersion }
// A sent or refused photo keeps its record (the photo list shows it) but
// not its image bytes once the server has them or has refused them.

const DB_NAME = 'arscout-scout';
const DB_VERSION = 1;
const PHOTOS = 'photos';
const SETTINGS = 'settings';

/** Wraps an IDBRequest in a promise. */
function done(request) {
  return new Promise((resolve, reject) => {
    request.onsuccess = () => resolve(request.result);
    request.onerror = () => reject(request.error);
  });
}

/** Resolves when a transaction commits, rejects when it aborts. */
function committed(tx) {
  return new Promise((resolve, reject) => {
    tx.oncomplete = () => resolve();
    tx.onabort = tx.onerror = () => reject(tx.error || new Error('IndexedDB transaction aborted'));
  });
}

function openDatabase() {
  const request = indexedDB.open(DB_NAME, DB_VERSION);
  request.onupgradeneeded = () => {
    const db = request.result;
    if (!db.objectStoreNames.contains(PHOTOS)) {
      db.createObjectStore(PHOTOS, { keyPath: 'captureId' }).createIndex('seq', 'seq', { unique: true });
    }
    if (!db.objectStoreNames.contains(SETTINGS)) db.createObjectStore(SETTINGS);
  };
  return done(request);
}

/** A short random device id: letters and digits, valid in a capture id. */
function newDeviceId() {
  const bytes = crypto.getRandomValues(new Uint8Array(6));
  return 'ph' + Array.from(bytes, (b) => b.toString(36).padStart(2, '0')).join('').slice(0, 10);
}

export class PhotoStore {
  static async open() {
    return new PhotoStore(await openDatabase());
  }

  constructor(db) {
    this.db = db;
  }

  /** The device's id, made on first use and kept. */
  async deviceId() {
    const tx = this.db.transaction(SETTINGS, 'readwrite');
    const settings = tx.objectStore(SETTINGS);
    let id = await done(settings.get('device'));
    if (!id) {
      id = newDeviceId();
      settings.put(id, 'device');
    }
    await committed(tx);
    return id;
  }

  /**
   * Stores a new photo and returns its record. `make(captureId, seq)`
   * returns the record's fields; it runs inside the transaction that takes
   * the counter, so it must not wait on anything.
   */
  async add(make) {
    const device = await this.deviceId();
    const tx = this.db.transaction([SETTINGS, PHOTOS], 'readwrite');
    const settings = tx.objectStore(SETTINGS);
    const seq = ((await done(settings.get('counter'))) || 0) + 1;
    settings.put(seq, 'counter');
    const captureId = `${device}-${String(seq).padStart(5, '0')}`;
    const record = { ...make(captureId, seq), captureId, seq, attempts: 0, error: '' };
    tx.objectStore(PHOTOS).add(record);
    await committed(tx);
    return record;
  }

  /** Every photo, oldest first. */
  async all() {
    const tx = this.db.transaction(PHOTOS);
    const records = await done(tx.objectStore(PHOTOS).index('seq').getAll());
    return records;
  }

  async get(captureId) {
    return done(this.db.transaction(PHOTOS).objectStore(PHOTOS).get(captureId));
  }

  /** Merges `changes` into a photo's record; returns the new record or null. */
  async update(captureId, changes) {
    const tx = this.db.transaction(PHOTOS, 'readwrite');
    const photos = tx.objectStore(PHOTOS);
    const record = await done(photos.get(captureId));
    if (!record) {
      await committed(tx);
      return null;
    }
    const next = { ...record, ...changes };
    photos.put(next);
    await committed(tx);
    return next;
  }

  /** A kept setting (the token, the server's address), or `fallback`. */
  async setting(key, fallback = null) {
    const value = await done(this.db.transaction(SETTINGS).objectStore(SETTINGS).get(key));
    return value === undefined ? fallback : value;
  }

  async setSetting(key, value) {
    const tx = this.db.transaction(SETTINGS, 'readwrite');
    if (value === null) tx.objectStore(SETTINGS).delete(key);
    else tx.objectStore(SETTINGS).put(value, key);
    await committed(tx);
  }
}
