-- arscout document store, SQLite schema version 1.
-- Applied by the store on open; recorded in schema_migrations.

-- Every document ever written, live or a tombstone (deleted = 1). Tombstones
-- keep the version count so a re-created document continues it.
CREATE TABLE documents (
  path       TEXT    NOT NULL PRIMARY KEY,
  parent     TEXT    NOT NULL,
  depth      INTEGER NOT NULL,
  kind       TEXT    NOT NULL,
  attrs      TEXT    NOT NULL,           -- JSON object
  blobs      TEXT    NOT NULL,           -- JSON object: name -> sha256
  version    INTEGER NOT NULL,
  seq        INTEGER NOT NULL,
  created_us INTEGER NOT NULL,
  updated_us INTEGER NOT NULL,
  author     TEXT    NOT NULL,
  deleted    INTEGER NOT NULL DEFAULT 0,
  lat        REAL,                       -- attrs.gps.lat, for radius queries
  lon        REAL
);
CREATE INDEX documents_by_parent ON documents (parent, path) WHERE deleted = 0;
CREATE INDEX documents_by_position ON documents (lat, lon)
  WHERE deleted = 0 AND lat IS NOT NULL;

-- The change log: one row per committed operation, seq in commit order.
CREATE TABLE changes (
  seq     INTEGER NOT NULL PRIMARY KEY,
  path    TEXT    NOT NULL,
  op      TEXT    NOT NULL,              -- put | patch | delete
  version INTEGER NOT NULL,
  kind    TEXT    NOT NULL,
  author  TEXT    NOT NULL,
  time_us INTEGER NOT NULL
);

-- The next change seq; its row is written by every write transaction.
CREATE TABLE counters (
  name  TEXT    NOT NULL PRIMARY KEY,
  value INTEGER NOT NULL
);
INSERT INTO counters (name, value) VALUES ('seq', 0);

-- Content-addressed blobs, stored as 1 MiB chunks so that no reader or
-- writer holds more than a chunk, and ranges read only what they need.
CREATE TABLE blobs (
  sha256      TEXT    NOT NULL PRIMARY KEY,
  size        INTEGER NOT NULL,
  chunk_bytes INTEGER NOT NULL,
  created_us  INTEGER NOT NULL
);
-- blob_key is a blob's sha256, or an upload id while it is being written.
CREATE TABLE blob_chunks (
  blob_key TEXT    NOT NULL,
  idx      INTEGER NOT NULL,
  data     BLOB    NOT NULL,
  PRIMARY KEY (blob_key, idx)
);
CREATE TABLE blob_uploads (
  upload_id  TEXT    NOT NULL PRIMARY KEY,
  started_us INTEGER NOT NULL
);
-- Which live document refers to which blob (for garbage collection).
CREATE TABLE blob_refs (
  path   TEXT NOT NULL,
  sha256 TEXT NOT NULL,
  PRIMARY KEY (path, sha256)
);
CREATE INDEX blob_refs_by_blob ON blob_refs (sha256);
