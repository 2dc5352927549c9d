-- arscout document store, PostgreSQL schema version 2: leases.
-- Named, time-limited claims by which engine workers share out sites
-- (Store::claim_leases). Claims lock rows with FOR UPDATE SKIP LOCKED, so
-- workers claiming at once take different sites instead of waiting for one
-- another. Coordination state, not documents: no change-log rows.
CREATE TABLE leases (
  name       text   NOT NULL PRIMARY KEY,
  holder     text,                        -- NULL: free
  expires_at timestamptz,                 -- database clock
  generation bigint NOT NULL DEFAULT 0    -- +1 whenever the holder changes
);
