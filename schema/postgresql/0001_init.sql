-- arscout document store, PostgreSQL schema version 1.
-- Applied by the store on open (under an advisory lock, so several servers
-- and workers may start at once); recorded in schema_migrations.

-- Paths compare bytewise (COLLATE "C") so prefix ranges use the index.
CREATE TABLE documents (
  path       TEXT COLLATE "C" NOT NULL PRIMARY KEY,
  parent     TEXT COLLATE "C" NOT NULL,
  depth      INTEGER NOT NULL,
  kind       TEXT    NOT NULL,
  attrs      JSONB   NOT NULL,
  blobs      JSONB   NOT NULL,
  version    BIGINT  NOT NULL,
  seq        BIGINT  NOT NULL,
  created_us BIGINT  NOT NULL,
  updated_us BIGINT  NOT NULL,
  author     TEXT    NOT NULL,
  deleted    SMALLINT NOT NULL DEFAULT 0,       -- 1: tombstone
  lat        DOUBLE PRECISION,
  lon        DOUBLE PRECISION
);
CREATE INDEX documents_by_parent ON documents (parent, path) WHERE deleted = 0;
CREATE INDEX documents_by_position ON documents (lat, lon)
  WHERE deleted = 0 AND lat IS NOT NULL;
CREATE INDEX documents_by_attrs ON documents USING GIN (attrs jsonb_path_ops)
  WHERE deleted = 0;

CREATE TABLE changes (
  seq     BIGINT NOT NULL PRIMARY KEY,
  path    TEXT COLLATE "C" NOT NULL,
  op      TEXT   NOT NULL,
  version BIGINT NOT NULL,
  kind    TEXT   NOT NULL,
  author  TEXT   NOT NULL,
  time_us BIGINT NOT NULL
);

-- Every write transaction first locks and bumps this row: that lock
-- serialises writers so seqs are handed out in commit order with no holes.
CREATE TABLE counters (
  name  TEXT   NOT NULL PRIMARY KEY,
  value BIGINT NOT NULL
);
INSERT INTO counters (name, value) VALUES ('seq', 0);

CREATE TABLE blobs (
  sha256      TEXT   NOT NULL PRIMARY KEY,
  size        BIGINT NOT NULL,
  chunk_bytes BIGINT NOT NULL,
  created_us  BIGINT NOT NULL
);
CREATE TABLE blob_chunks (
  blob_key TEXT    NOT NULL,
  idx      INTEGER NOT NULL,
  data     BYTEA   NOT NULL,
  PRIMARY KEY (blob_key, idx)
);
ALTER TABLE blob_chunks ALTER COLUMN data SET STORAGE EXTERNAL;
CREATE TABLE blob_uploads (
  upload_id  TEXT   NOT NULL PRIMARY KEY,
  started_us BIGINT NOT NULL
);
CREATE TABLE blob_refs (
  path   TEXT COLLATE "C" NOT NULL,
  sha256 TEXT NOT NULL,
  PRIMARY KEY (path, sha256)
);
CREATE INDEX blob_refs_by_blob ON blob_refs (sha256);
