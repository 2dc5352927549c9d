// `arscout reconstruct` on a short synthetic scouting walk round a city
// block (`arscout render-site --scene block`): 60 photos of 640 x 480 with
// exact poses and noisy GPS, so it needs no ../shared/data and runs in CI's
// default build (label engine-synthetic, a few minutes on 2 cores). The
// small brother of bench/scale_bench (400 photos): registration, accuracy
// after a similarity fit, geo-registration against the noise-free fixes,
// and an increment cost that stays flat along the walk.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/util/file.h"
#include "model_eval.h"
#include "progress_log.h"
#include "run_cli.h"
#include "test_stores.h"

namespace arscout {
namespace {

using testing::run_cli;

constexpr int kViews = 60;

TEST(BlockWalk, SixtyPhotosRegisterAccuratelyAtAFlatIncrementCost) {
  const std::string work = testing::make_temp_dir("block-walk");
  // Removed when the test passes; kept (site/, out/, *.log) otherwise.
  std::cout << "block walk in " << work << std::endl;
  const std::string site = work + "/site";
  const std::string out = work + "/out";
  run_cli({"render-site", "--scene", "block", "--views", std::to_string(kViews),
           "--width", "640", "--height", "480", "--seed", "11", "--out", site},
          work + "/render.log");
  if (HasFatalFailure()) return;
  run_cli({"reconstruct", "--images", site + "/images", "--gps-csv",
           site + "/gps.csv", "--camera", site + "/images/K.txt", "--out", out},
          work + "/reconstruct.log");
  if (HasFatalFailure()) return;

  // The increments first: they mean something even when the model does not.
  const eval::ProgressLog log =
      eval::read_progress_log(work + "/reconstruct.log");
  const double p95_early = eval::percentile(eval::increments(log, 11, 30), .95);
  const double p95_late = eval::percentile(eval::increments(log, 41, 60), .95);
  std::cout << "block walk: increment p95 photos 11-30 " << p95_early
            << " s, 41-60 " << p95_late << " s; refine " << log.refine_seconds()
            << " s" << std::endl;
  EXPECT_EQ(log.photos.size(), static_cast<std::size_t>(kViews));
  // A flat increment cost, as a ratio within the run and never an absolute
  // time: CI machines differ and are shared. The factor is 2.0 rather than
  // the 1.25 bench/scale_bench asks of 400 photos because the windows here
  // hold 20 photos each, so their p95 is close to their maximum, and one
  // photo slowed by a neighbour on a shared 2-core machine moves it a lot.
  EXPECT_FALSE(std::isnan(p95_early) || std::isnan(p95_late));
  EXPECT_LE(p95_late, 2.0 * p95_early);

  const auto estimated =
      eval::read_colmap_images_txt(out + "/sparse/images.txt");
  EXPECT_GE(estimated.size(), static_cast<std::size_t>(kViews - 2));
  ASSERT_GE(estimated.size(), 3u) << "the similarity fit needs three cameras";
  const auto poses = eval::compare_to_ground_truth(
      estimated, eval::read_strecha_ground_truth(site + "/gt_dense_cameras"));
  int geo_matched = 0;
  const double geo_median_m = eval::median_geo_distance(
      eval::read_geo_csv(out + "/cameras_geo.csv"),
      eval::read_geo_csv(site + "/gps_truth.csv"), &geo_matched);
  std::cout << "block walk: " << poses.matched << "/" << kViews
            << " registered, centre error median " << poses.median_centre_error
            << " m, max " << poses.max_centre_error << " m; geo median "
            << geo_median_m << " m over " << geo_matched << std::endl;
  EXPECT_GE(poses.matched, kViews - 2);
  // The scene is in metres: issue 17's targets, median 0.02 m and max
  // 0.10 m after the similarity fit (measured 2026-11-24: 0.0076 m and
  // 0.035 m). A photo that registers in the mirror minimum of a wall's
  // planar pose ambiguity (17 degrees and 1.3 m off, before SQPnP) fails the
  // max on its own.
  EXPECT_LE(poses.median_centre_error, 0.02);
  EXPECT_LE(poses.max_centre_error, 0.10);
  // The fixes are off by 1.5 m per horizontal axis and 3 m vertically.
  EXPECT_GE(geo_matched, kViews - 2);
  EXPECT_LE(geo_median_m, 1.0);

  if (!HasFailure()) std::filesystem::remove_all(work);
}

// A rendered photo's name: 0007.jpg.
std::string photo_name(int index) {
  std::ostringstream name;
  name << std::setw(4) << std::setfill('0') << index << ".jpg";
  return name.str();
}

// The walk's photos renamed so that file-name order feeds the groups in the
// order given (each a range of indices, named with its letter), so that a
// later stretch of the walk can come before the way to it: it waits, seeing
// nothing the model has, until the way reaches it. Fixes and truths follow
// the new names.
void reorder_walk(
    const std::string& from, const std::string& to,
    const std::vector<std::pair<char, std::pair<int, int>>>& groups) {
  namespace fs = std::filesystem;
  fs::create_directories(to + "/images");
  fs::create_directories(to + "/gt_dense_cameras");
  fs::copy_file(from + "/images/K.txt", to + "/images/K.txt");
  std::map<std::string, std::string> renamed;
  for (const auto& [group, range] : groups) {
    for (int i = range.first; i <= range.second; ++i) {
      const std::string old_name = photo_name(i);
      const std::string name = group + old_name;
      renamed[old_name] = name;
      fs::copy_file(from + "/images/" + old_name, to + "/images/" + name);
      fs::copy_file(from + "/gt_dense_cameras/" + old_name + ".camera",
                    to + "/gt_dense_cameras/" + name + ".camera");
    }
  }
  for (const std::string csv : {"/gps.csv", "/gps_truth.csv"}) {
    std::ifstream in(from + csv);
    std::ofstream out(to + csv);
    std::string line;
    std::getline(in, line);
    out << line << "\n";
    while (std::getline(in, line)) {
      const std::string image = line.substr(0, line.find(','));
      if (renamed.count(image))
        out << renamed.at(image) << line.substr(image.size()) << "\n";
    }
  }
}

// The 40-photo loop round a block (640 x 480, seed 11) rendered into
// WORK/rendered and fed reordered as WORK/site (reorder_walk).
void render_reordered_loop(
    const std::string& work,
    const std::vector<std::pair<char, std::pair<int, int>>>& groups) {
  const std::string rendered = work + "/rendered";
  run_cli({"render-site", "--scene", "block", "--views", "40", "--width", "640",
           "--height", "480", "--seed", "11", "--out", rendered},
          work + "/render.log");
  if (::testing::Test::HasFatalFailure()) return;
  reorder_walk(rendered, work + "/site", groups);
}

// The walk fed with a gap: the far side of the block (photos 16-25) comes
// before the way there (8-15).
//
// As one chain (--single-model, COLMAP's multiple_models 0) the far side
// waits, seeing nothing the model has, until the way reaches it; the photo
// that links them frees the whole stretch at once. Its increment registers
// at most --max-registrations of them and the refinement between photos
// registers the rest.
//
// With components (the default) the far side starts a component of its
// own as it arrives, placed in ENU by its fixes, so no photo waits: two
// components, then one once the way there is photographed and a photo
// matches both (docs/engine.md, "Components"). In the end both models are
// complete and about as good.
TEST(BlockWalk, AGapGivesTwoComponentsThenOneOrAWaitInOneChain) {
  const std::string work = testing::make_temp_dir("block-walk-gap");
  std::cout << "block walk with a gap in " << work << std::endl;
  const std::string site = work + "/site";
  render_reordered_loop(
      work, {{'a', {0, 7}}, {'b', {16, 25}}, {'c', {8, 15}}, {'d', {26, 39}}});
  if (HasFatalFailure()) return;
  constexpr int kLimit = 3;
  eval::PoseComparison poses[2];
  for (const bool chain : {true, false}) {
    const std::string out = work + (chain ? "/chain" : "/components");
    const std::string log_path = out + ".log";
    std::vector<std::string> args{"reconstruct",
                                  "--images",
                                  site + "/images",
                                  "--gps-csv",
                                  site + "/gps.csv",
                                  "--camera",
                                  site + "/images/K.txt",
                                  "--out",
                                  out,
                                  "--deterministic"};
    if (chain) {
      args.insert(args.end(), {"--single-model", "--max-registrations",
                               std::to_string(kLimit)});
    }
    run_cli(args, log_path);
    if (HasFatalFailure()) return;
    const eval::ProgressLog log = eval::read_progress_log(log_path);
    // By one increment, after the one that made the initial model (whose
    // photos the limit does not count).
    size_t most = 0;
    bool initialized = false;
    std::set<int> far_side;  // components the far side registered in
    int merged = 0;
    for (const eval::PhotoProgress& photo : log.photos) {
      const size_t count =
          photo.also_registered.size() + (photo.status == "registered" ? 1 : 0);
      if (initialized) most = std::max(most, count);
      initialized = initialized || count > 0;
      if (photo.name[0] == 'b' && photo.component >= 0)
        far_side.insert(photo.component);
      merged += photo.merged;
    }
    merged += log.components_merged;
    eval::PoseComparison& p = poses[chain ? 0 : 1];
    p = eval::compare_to_ground_truth(
        eval::read_colmap_images_txt(out + "/sparse/images.txt"),
        eval::read_strecha_ground_truth(site + "/gt_dense_cameras"));
    const std::string text = util::read_file(log_path);
    std::cout << "block walk with a gap, "
              << (chain ? "one chain" : "components") << ": at most " << most
              << " registered by one increment, " << log.waiting_registered
              << " by the refinement, " << far_side.size()
              << " component(s) on the far side, " << merged << " merge(s); "
              << p.matched << "/40 registered, centre error median "
              << p.median_centre_error << " m, max " << p.max_centre_error
              << " m" << std::endl;
    EXPECT_EQ(p.matched, 40);
    EXPECT_NE(text.find("registered 40 images in 1 component,"),
              std::string::npos);
    if (chain) {
      EXPECT_LE(most, static_cast<size_t>(kLimit));
      EXPECT_GE(log.waiting_registered, 3) << "no photo waited for the limit";
      EXPECT_EQ(merged, 0);
    } else {
      // The far side registered in a component of its own as it came...
      int first_component = -1;
      for (const eval::PhotoProgress& photo : log.photos) {
        if (photo.name[0] == 'a' && photo.component >= 0) {
          first_component = photo.component;
          break;
        }
      }
      EXPECT_GE(first_component, 0);
      EXPECT_FALSE(far_side.empty());
      EXPECT_FALSE(far_side.count(first_component))
          << "the far side joined the first component directly";
      int far_registered = 0;
      for (const eval::PhotoProgress& photo : log.photos) {
        if (photo.name[0] == 'b')
          far_registered += photo.status == "registered";
      }
      EXPECT_GE(far_registered, 7) << "the far side waited";
      // ... and the two merged once the way there was photographed.
      EXPECT_GE(merged, 1);
      EXPECT_EQ(log.waiting_registered, 0);
    }
  }
  // Deterministic runs: a wall-clock refinement budget made the components
  // run's accuracy depend on the machine's load (5 cm once on CI, 1.3 cm
  // here), so that neither run's figure depends on how busy CI is.
  EXPECT_LE(poses[1].median_centre_error, poses[0].median_centre_error + 0.03);
  EXPECT_LE(poses[1].max_centre_error, poses[0].max_centre_error + 0.06);
  if (!HasFailure()) std::filesystem::remove_all(work);
}

// A fragment that stops growing is retired: four photos of the far side
// (25-28) come early and start a component of their own; the walk then
// stays on the near side for longer than --retire-after, so the fragment
// is retired and its photos wait; once the walk reaches them they register
// into the one component (docs/engine.md, "Components").
TEST(BlockWalk, AStalledFragmentIsRetiredAndItsPhotosJoinLater) {
  const std::string work = testing::make_temp_dir("block-walk-retire");
  std::cout << "block walk with a stalled fragment in " << work << std::endl;
  const std::string site = work + "/site";
  render_reordered_loop(work, {{'a', {0, 9}},
                               {'b', {25, 28}},
                               {'c', {10, 19}},
                               {'d', {20, 24}},
                               {'e', {29, 39}}});
  if (HasFatalFailure()) return;
  const std::string out = work + "/out";
  run_cli({"reconstruct", "--images", site + "/images", "--gps-csv",
           site + "/gps.csv", "--camera", site + "/images/K.txt", "--out", out,
           "--retire-below", "5", "--retire-after", "8"},
          out + ".log");
  if (HasFatalFailure()) return;
  const eval::ProgressLog log = eval::read_progress_log(out + ".log");
  int first_component = -1, fragment = -1, retired = 0;
  for (const eval::PhotoProgress& photo : log.photos) {
    if (photo.name[0] == 'a' && first_component < 0 && photo.component >= 0)
      first_component = photo.component;
    if (photo.name[0] == 'b' && photo.component >= 0)
      fragment = photo.component;
    retired += photo.retired;
  }
  const eval::PoseComparison p = eval::compare_to_ground_truth(
      eval::read_colmap_images_txt(out + "/sparse/images.txt"),
      eval::read_strecha_ground_truth(site + "/gt_dense_cameras"));
  const std::string text = util::read_file(out + ".log");
  std::cout << "stalled fragment: component " << fragment << " (first "
            << first_component << "), " << retired << " retired; " << p.matched
            << "/40 registered, centre error median " << p.median_centre_error
            << " m, max " << p.max_centre_error << " m" << std::endl;
  EXPECT_GE(fragment, 0) << "the far side's photos started no component";
  EXPECT_NE(fragment, first_component);
  EXPECT_EQ(retired, 1);
  EXPECT_EQ(p.matched, 40);
  EXPECT_NE(text.find("registered 40 images in 1 component,"),
            std::string::npos);
  if (!HasFailure()) std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace arscout
