-- arscout document store, SQLite schema version 2: leases.
-- Named, time-limited claims by which engine workers share out sites
-- (Store::claim_leases). Coordination state, not documents: no change-log
-- rows, no versions.
CREATE TABLE leases (
  name       TEXT    NOT NULL PRIMARY KEY,
  holder     TEXT,                       -- NULL: free
  expires_at REAL,                       -- Unix seconds, database clock
  generation INTEGER NOT NULL DEFAULT 0  -- +1 whenever the holder changes
);
