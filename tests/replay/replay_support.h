// What every replay regression test does (docs/sessions.md): find the
// session a fixture recorded, replay it into an empty store with an engine
// following it, read the model's cameras in the evaluation library's terms,
// and judge a table of statistics against expected ranges, printing the
// whole table, expected against got, so a failure reads as a diff.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/engine/service.h"
#include "arscout/ingest/session.h"
#include "model_eval.h"

namespace arscout::replay {

// One expected statistic: a name, what was measured, the allowed range.
struct Row {
  std::string name;
  double got;
  double min;
  double max;
  bool ok() const { return got >= min && got <= max; }
};

std::string table(const std::vector<Row>& rows);

// Prints the table, and fails the test with it when a row is out of range.
void expect_rows_within(const std::vector<Row>& rows);

// The session file a record_session.sh fixture left in `dir` (DIR/NAME.session
// beside DIR/ready), or "" after reporting why not: a skip, or a failure
// under CI=true, where every fixture must have run.
std::string recorded_session(const std::string& dir, const std::string& name);

struct Replayed {
  std::unique_ptr<db::Store> store;
  ingest::ReplaySummary summary;
  int sites = 0;
  // The model of the site with the most registered captures; nullopt when
  // the engine wrote none or was not idle with its dense cloud current
  // within the timeout.
  std::optional<db::Document> model;
  double seconds = 0;  // from the replay's start to the engine's idle
};

// Replays `session` into a new SQLite store with an engine following it,
// its dense cloud at a reduced resolution (480 px long side), and waits for
// the engine to finish what the session caused.
Replayed replay_with_engine(const std::string& session,
                            engine::WorkerOptions options,
                            const ingest::ReplayOptions& replay,
                            std::chrono::seconds timeout);

// The regression tests' replay: the whole session at once (`--fast`) into an
// engine run `--deterministic`, so that the model, dense cloud included,
// does not depend on how this machine's timing folds captures into
// increments (docs/sessions.md). Prints how long it took.
Replayed replay_deterministically(const std::string& session,
                                  std::chrono::seconds timeout);

// A model document's cameras keyed by photo file name: capture ids are
// "SCOUT-FILE" (`arscout scout`), the ground truth is keyed by FILE.
std::map<std::string, eval::Pose> model_poses(const db::Json& model);
// Their geo-registered positions, as the model puts them on the globe.
std::map<std::string, eval::GeoRow> model_positions(const db::Json& model);
// The GPS fix each of the store's captures came with, keyed as above.
std::map<std::string, eval::GeoRow> capture_fixes(db::Store& store);

// Median horizontal distance in metres between rows of the same name.
// Phone altitudes are far worse than their positions (lund's EXIF), so
// this is the GPS agreement that means something there.
double median_horizontal_distance(std::map<std::string, eval::GeoRow> a,
                                  std::map<std::string, eval::GeoRow> b);

// The number of points in the model's dense cloud (0 when it has none).
double dense_point_count(db::Store& store, const db::Document& model);

}  // namespace arscout::replay
