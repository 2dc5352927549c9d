// A phase of a site's reconstruction: it takes the site's job (its state)
// and returns one increment to commit (site_commit.h). The lanes decide
// when a phase runs (site_schedule.h); a phase only says what it does. The
// phases of today are the sparse increment (captures added, withdrawn), the
// dense phase (its publication, after the sweep that runs outside the
// publication order), the global refinement, a merge of another site into
// this one, and the save of a quiet site's engine state; a new one (the
// surface mesh) is a class here and the lane that schedules it.
#pragma once

#include <cstdint>
#include <functional>
#include <string_view>
#include <vector>

#include "arscout/util/histogram.h"
#include "site_job.h"

namespace arscout::engine::service {

class Phase {
 public:
  virtual ~Phase() = default;
  virtual std::string_view name() const = 0;
  // The increment to commit. The caller holds job.publication() (two
  // jobs' for a merge); throws what the job throws.
  virtual Increment run(SiteJob& job) = 0;
};

// Runs `phase` on `job`, timing it into the increment's summary and into
// `clock` (when given).
Increment run_phase(Phase& phase, SiteJob& job, util::Histogram* clock);

// The captures of one increment (SiteJob::run).
class SparsePhase : public Phase {
 public:
  SparsePhase(const std::vector<Work>& work, std::int64_t settled_through,
              bool save_state)
      : work_(work), through_(settled_through), save_state_(save_state) {}
  std::string_view name() const override { return "sparse"; }
  Increment run(SiteJob& job) override {
    return job.run(work_, through_, save_state_);
  }

 private:
  const std::vector<Work>& work_;
  std::int64_t through_;
  bool save_state_;
};

// The dense phase in one step (deterministic runs, SiteJob::run_dense).
class DensePhase : public Phase {
 public:
  std::string_view name() const override { return "dense"; }
  Increment run(SiteJob& job) override { return job.run_dense(); }
};

// A dense lane's publication of what it swept (SiteJob::finish_dense).
class DensePublication : public Phase {
 public:
  explicit DensePublication(DenseTask& task) : task_(task) {}
  std::string_view name() const override { return "dense"; }
  Increment run(SiteJob& job) override { return job.finish_dense(task_); }

 private:
  DenseTask& task_;
};

// One round of the global refinement, stopping when `stop` says so
// (SiteJob::run_refine).
class RefinePhase : public Phase {
 public:
  explicit RefinePhase(std::function<bool()> stop) : stop_(std::move(stop)) {}
  std::string_view name() const override { return "refine"; }
  Increment run(SiteJob& job) override { return job.run_refine(stop_); }

 private:
  std::function<bool()> stop_;
};

// Another site taken into this one (SiteJob::absorb).
class MergePhase : public Phase {
 public:
  explicit MergePhase(SiteJob& other) : other_(other) {}
  std::string_view name() const override { return "merge"; }
  Increment run(SiteJob& job) override { return job.absorb(other_); }

 private:
  SiteJob& other_;
};

// A quiet site's engine state saved (SiteJob::save_state).
class SaveStatePhase : public Phase {
 public:
  std::string_view name() const override { return "save-state"; }
  Increment run(SiteJob& job) override { return job.save_state(); }
};

}  // namespace arscout::engine::service
