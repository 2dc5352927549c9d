// `arscout reconstruct`: the reconstruction core over a folder of photos,
// fed one at a time in file-name order as the engine service will feed it,
// with a progress line per photo; writes the COLMAP text model, the camera
// table and a PLY of the sparse points, and with --dense grows the dense
// cloud after every photo and writes it too.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "arscout/documents/capture_status.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/image_size.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/model_io.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/reconstruction.h"
#include "arscout/metadata/gps.h"
#include "arscout/util/error.h"
#include "arscout/util/file.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;

struct ReconstructArgs {
  std::string images;
  std::string gps_csv;
  std::string camera;
  std::string out;
  std::string resume;
  std::string save_state;
  int limit = 0;
  engine::ReconstructionOptions options;
  bool dense = false;
  bool mesh = false;
  bool mesh_check = false;
  engine::DenseOptions dense_options;
  double refine_budget_s = 2.0;
};

class InputSource {
 public:
  explicit InputSource(const ReconstructArgs& a) : args_(a) {
    if (!a.gps_csv.empty()) {
      try {
        csv_ = metadata::read_gps_csv(a.gps_csv);
      } catch (const std::runtime_error& e) {
        throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
      }
    }
  }

  engine::CaptureInput load(const std::string& path) {
    engine::CaptureInput input;
    input.id = fs::path(path).filename().string();
    input.image_bytes = read_input_file(path);
    const auto size = engine::read_image_size(input.image_bytes);
    const metadata::ExifInfo exif = metadata::read_exif(input.image_bytes);
    input.camera_id = camera_id(exif, size);
    input.camera = camera(exif, size, path);
    input.gps = gps(input.id, exif);
    return input;
  }

 private:
  std::string camera_id(const metadata::ExifInfo& exif,
                        const std::optional<engine::ImageSize>& size) const {
    if (!args_.camera.empty()) return "K:" + args_.camera;
    std::ostringstream id;
    id << "exif:" << exif.make << ":" << exif.model << ":"
       << exif.focal_mm.value_or(0) << ":" << (size ? size->width : 0) << "x"
       << (size ? size->height : 0);
    return id.str();
  }

  std::optional<engine::CameraIntrinsics> camera(
      const metadata::ExifInfo& exif,
      const std::optional<engine::ImageSize>& size,
      const std::string& path) const {
    if (!size) {
      throw util::Error(util::ErrorKind::kInvalidArgument,
                        path + ": not a JPEG or PNG with a size");
    }
    if (!args_.camera.empty()) {
      try {
        return engine::read_k_matrix(args_.camera, size->width, size->height);
      } catch (const std::runtime_error& e) {
        throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
      }
    }
    const auto focal = engine::focal_px_from_exif(
        size->width, size->height, exif.focal_35mm, exif.focal_mm,
        exif.focal_plane_x_res, exif.focal_plane_unit_mm);
    if (!focal) return std::nullopt;  // the engine guesses, and refines
    return engine::centred_camera(size->width, size->height, *focal, "exif");
  }

  std::optional<engine::GeoFix> gps(const std::string& name,
                                    const metadata::ExifInfo& exif) const {
    if (!args_.gps_csv.empty()) {
      auto it = csv_.find(name);
      if (it == csv_.end()) return std::nullopt;
      return engine::geo_fix_of(it->second);
    }
    if (exif.gps) return engine::geo_fix_of(*exif.gps);
    return std::nullopt;
  }

  const ReconstructArgs& args_;
  std::map<std::string, metadata::GpsFix> csv_;
};

void print_progress(int n, int total, const engine::AddResult& r,
                    double model_error_px) {
  const auto& t = r.timings;
  std::cout << std::fixed << std::setprecision(2) << "[" << n << "/" << total
            << "] " << r.id << "  " << documents::to_string(r.status);
  if (!r.reason.empty()) std::cout << " (" << r.reason << ")";
  std::cout << "  features " << r.features << "  pairs " << r.matched_pairs
            << "  inliers " << r.pose_inliers << "  reproj "
            << std::setprecision(3) << model_error_px << " px"
            << std::setprecision(2) << (r.geo_registered ? "  geo" : "")
            << (r.loops_closed ? "  loop closed" : "");
  if (r.component >= 0) std::cout << "  component " << r.component;
  if (r.components_merged > 0) std::cout << "  merged " << r.components_merged;
  if (r.components_retired > 0)
    std::cout << "  retired " << r.components_retired;
  std::cout << "  | decode " << t.decode_s << " undistort " << t.undistort_s
            << " features " << t.features_s << " match " << t.matching_s
            << " pose " << t.pose_s << " triang " << t.triangulation_s << " ba "
            << t.bundle_adjustment_s << " total " << t.total_s << " s";
  if (!r.also_registered.empty()) {
    std::cout << "  (also registered:";
    for (const auto& id : r.also_registered) std::cout << ' ' << id;
    std::cout << ")";
  }
  std::cout << std::endl;
}

void print_dense_progress(const engine::DenseUpdate& u) {
  if (u.new_depth_maps.empty() && u.covered.empty() && !u.refused &&
      u.refused_maps == 0)
    return;
  std::cout << std::fixed << std::setprecision(2)
            << "      dense: " << u.new_depth_maps.size() << " new depth map"
            << (u.new_depth_maps.size() == 1 ? "" : "s");
  for (const auto& id : u.new_depth_maps) std::cout << ' ' << id;
  if (!u.skipped.empty())
    std::cout << "  (waiting: " << u.skipped.size() << ")";
  if (!u.covered.empty())
    std::cout << "  (covered by the key views: " << u.covered.size() << ")";
  std::cout << "  points " << u.points;
  if (u.refused)
    std::cout << " (re-fused)";
  else if (u.refused_maps > 0)
    std::cout << " (" << u.refused_maps << " moved re-fused)";
  if (u.deferred_maps > 0)
    std::cout << " (" << u.deferred_maps << " moved left for later)";
  std::cout << "  | sweep " << u.sweep_s << " filter " << u.filter_s
            << " fusion " << u.fusion_s << " s" << std::endl;
}

void print_refine(const engine::RefineResult& r) {
  if (!r.ran) return;
  if (r.components_merged > 0) {
    std::cout << std::fixed << std::setprecision(2)
              << "      components merged: " << r.components_merged << ", "
              << r.seconds << " s" << std::endl;
    return;
  }
  if (!r.registered.empty()) {
    std::cout << std::fixed << std::setprecision(2)
              << "      waiting registered: " << r.registered.size() << " (";
    for (size_t i = 0; i < r.registered.size(); ++i)
      std::cout << (i ? " " : "") << r.registered[i];
    std::cout << "), " << r.seconds << " s"
              << (r.converged ? "" : " (given way)") << std::endl;
    return;
  }
  std::cout << std::fixed << std::setprecision(2)
            << "      refine: " << r.images << " images, " << r.iterations
            << " iterations, " << r.seconds << " s, keypoints "
            << std::setprecision(3) << r.pixel_sigma << " px, loss "
            << r.loss_scale_px << " px, cameras moved up to "
            << std::setprecision(4) << r.largest_move << std::setprecision(2)
            << ", " << r.tracks_joined << " matches joined, "
            << r.corners_matched << " weak corners matched, " << r.loose_links
            << " loose-pair matches linked (" << r.strained_links
            << " strained)" << (r.converged ? "" : " (given way)") << std::endl;
}

// The global adjustment in the gap before the next photo, as the service
// runs it while it waits: at most `budget_s` (it gives way after the
// iteration that passes it), continued after the next photo. A
// deterministic run lets each round finish instead, as the service's
// deterministic replays do: a clock must not decide the model.
void refine_between_photos(engine::Reconstruction& site, double budget_s,
                           bool deterministic) {
  if (budget_s <= 0 || !site.refinement_due()) return;
  if (deterministic) {
    print_refine(site.refine());
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  print_refine(site.refine([&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                         start)
               .count() > budget_s;
  }));
}

// Before the outputs: the captures still waiting, then the last photo's
// refinement, to the end (at most 10 rounds of the adjustment).
void refine_to_convergence(engine::Reconstruction& site) {
  for (int round = 0; round < 10 && site.refinement_due();) {
    const engine::RefineResult result = site.refine();
    print_refine(result);
    if (result.registered.empty() && result.components_merged == 0) ++round;
  }
}

// Photos by capture id (the file name) for the dense stage, which decodes
// them again at its own resolution.
engine::ImageSource folder_images(const std::string& dir) {
  return [dir](const std::string& id) {
    return read_input_file((fs::path(dir) / id).string());
  };
}

// What `arscout depth` needs to find the photos again.
void write_sources(const ReconstructArgs& a) {
  std::ofstream out(a.out + "/sources.txt");
  out << "images " << fs::absolute(a.images).string() << "\n";
}

engine::Reconstruction start(const ReconstructArgs& a) {
  if (a.resume.empty()) return engine::Reconstruction(a.options);
  try {
    return engine::Reconstruction::restore(read_input_file(a.resume),
                                           a.options);
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      a.resume + ": " + e.what());
  }
}

// The batch run's surface: the whole cloud as one tile, textured from every
// key view, its finest level as OUT/mesh.glb (docs/mesh.md).
// Each key view predicted by the surface textured from the others
// (engine::holdout_scores): OUT/mesh_check.csv and the median.
void write_mesh_check(const engine::TexturedMesh& surface,
                      const std::vector<engine::TextureView>& views,
                      const std::string& out) {
  const std::vector<engine::HoldoutScore> scores =
      engine::holdout_scores(surface, views);
  std::ostringstream csv;
  csv << "view,zncc,covered\n";
  std::vector<double> zncc, covered;
  for (const engine::HoldoutScore& s : scores) {
    csv << s.id << "," << s.zncc << "," << s.covered << "\n";
    zncc.push_back(s.zncc);
    covered.push_back(s.covered);
  }
  util::write_file_atomic(out + "/mesh_check.csv", csv.str());
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  std::cout << "mesh check: " << scores.size()
            << " views each predicted from the others, median ZNCC "
            << median(zncc) << ", median covered share " << median(covered)
            << ", wrote " << out << "/mesh_check.csv" << std::endl;
}

// `points`: the cloud as dense.ply has it (without its isolated points).
void write_mesh(const engine::DenseReconstruction& dense,
                const std::vector<engine::ColoredPoint>& points,
                const std::string& out, bool check) {
  const auto start = std::chrono::steady_clock::now();
  if (points.empty() || !(dense.voxel_size() > 0)) {
    std::cout << "mesh: no dense points, no mesh.glb" << std::endl;
    return;
  }
  const engine::TexturedMesh surface =
      engine::mesh_surface(points, Eigen::Vector2d::Constant(-1e6),
                           Eigen::Vector2d::Constant(1e6), dense.voxel_size());
  const std::vector<engine::TextureView> views =
      engine::texture_views(dense.key_views());
  const engine::TexturedMesh textured = engine::texture_mesh(surface, views);
  if (textured.empty()) {
    std::cout << "mesh: no surface, no mesh.glb" << std::endl;
    return;
  }
  util::write_file_atomic(out + "/mesh.glb", engine::encode_glb(textured));
  std::cout << "mesh: " << textured.triangles() << " triangles, atlas "
            << textured.atlas.cols << " x " << textured.atlas.rows << " ("
            << std::setprecision(2) << std::fixed
            << std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                             start)
                   .count()
            << " s), wrote " << out << "/mesh.glb" << std::defaultfloat
            << std::endl;
  if (check) write_mesh_check(surface, views, out);
}

void write_outputs(const engine::Reconstruction& site,
                   const engine::DenseReconstruction* dense,
                   const ReconstructArgs& a) {
  const engine::Model model = site.model();
  fs::create_directories(a.out);
  write_sources(a);
  if (dense) {
    const double voxel = dense->voxel_size();
    const auto points = engine::without_isolated_points(
        dense->points(), engine::kIsolatedRadiusVoxels * voxel,
        voxel > 0 ? engine::kIsolatedMinNeighbours : 0);
    engine::write_ply(a.out + "/dense.ply", points);
    std::cout << "dense cloud: " << points.size() << " points from "
              << dense->filtered_depth_maps().size() << " depth maps, wrote "
              << a.out << "/dense.ply" << std::endl;
    if (a.mesh) write_mesh(*dense, points, a.out, a.mesh_check);
  }
  engine::write_colmap_text(model, a.out + "/sparse");
  engine::write_geo_csv(model, a.out + "/cameras_geo.csv");
  engine::write_points_ply(model, a.out + "/sparse.ply");
  std::cout << "registered " << model.images.size() << " images in "
            << model.components.size()
            << (model.components.size() == 1 ? " component, " : " components, ")
            << model.points.size() << " points, mean reprojection error "
            << std::setprecision(3) << model.mean_reprojection_px << " px"
            << (model.geo_registered ? ", geo-registered (ENU)"
                                     : ", local frame (no GPS)")
            << "\nwrote " << a.out << "/sparse/, " << a.out
            << "/cameras_geo.csv, " << a.out << "/sparse.ply" << std::endl;
}

int run_reconstruct(const ReconstructArgs& a) {
  if (a.mesh_check && !a.mesh)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--mesh-check needs --mesh");
  if (a.mesh && !a.dense)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--mesh needs --dense: the surface is made from the "
                      "dense cloud");
  const std::vector<std::string> paths = list_image_files(a.images);
  InputSource source(a);
  engine::Reconstruction site = start(a);
  std::optional<engine::DenseReconstruction> dense;
  if (a.dense) dense.emplace(a.dense_options);
  const engine::ImageSource images = folder_images(a.images);
  std::set<std::string> done;
  for (const auto& state : site.captures()) done.insert(state.id);
  const auto begin = std::chrono::steady_clock::now();
  int n = 0, added = 0;
  install_stop_handlers();
  for (const std::string& path : paths) {
    ++n;
    if (done.count(fs::path(path).filename().string())) continue;
    if (a.limit > 0 && added >= a.limit) break;
    if (stop_requested()) break;
    engine::CaptureInput input = source.load(path);
    try {
      const engine::AddResult result = site.add_capture(input);
      print_progress(n, static_cast<int>(paths.size()), result,
                     site.mean_reprojection_px());
      refine_between_photos(site, a.refine_budget_s, a.options.deterministic);
      if (dense && site.registered_count() > 0)
        print_dense_progress(dense->update(site.model(), images));
    } catch (const std::invalid_argument& e) {
      std::cout << "[" << n << "/" << paths.size() << "] " << input.id
                << "  rejected (" << e.what() << ")" << std::endl;
    }
    ++added;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - begin)
          .count();
  std::cout << "added " << added << " images in " << std::setprecision(2)
            << std::fixed << seconds << " s" << std::defaultfloat << std::endl;
  refine_to_convergence(site);
  if (dense)
    print_dense_progress(
        engine::update_until_settled(*dense, site.model(), images));
  write_outputs(site, dense ? &*dense : nullptr, a);
  if (!a.save_state.empty()) {
    std::ofstream out(a.save_state, std::ios::binary);
    const std::string bytes = site.serialize();
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out)
      throw util::Error(util::ErrorKind::kInternal,
                        a.save_state + ": write failed");
  }
  return kExitOk;
}

void add_reconstruct_command(CLI::App& app) {
  static ReconstructArgs args;
  CLI::App* cmd =
      app.add_subcommand("reconstruct",
                         "incremental structure from motion over a folder of "
                         "photos, fed one at a time in "
                         "file-name order; writes OUT/sparse/ (COLMAP text "
                         "model), OUT/cameras_geo.csv, OUT/sparse.ply and, "
                         "with --dense, OUT/dense.ply");
  cmd->add_option("--images", args.images,
                  "folder of photos (.jpg .jpeg .png ...)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--gps-csv", args.gps_csv,
                  "fixes per image: "
                  "image,latitude,longitude,altitude,horizontal_accuracy_m,"
                  "vertical_accuracy_m (else the photos' EXIF GPS)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--camera", args.camera,
                  "3x3 K for every photo, as in Strecha's images/K.txt (else "
                  "the EXIF focal "
                  "length, else a guess; both refined)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args.out, "output folder")->required();
  cmd->add_option("--long-side", args.options.long_side,
                  "working resolution, long side in px")
      ->capture_default_str()
      ->check(CLI::Range(200, 10000));
  cmd->add_option("--max-features", args.options.max_features,
                  "Harris corners per image")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  cmd->add_option("--match-features", args.options.match_features,
                  "of those, the strongest that each increment matches; the "
                  "refinement matches the rest along epipolar lines")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  cmd->add_option("--gps-neighbours", args.options.gps_neighbours,
                  "match each photo with this many nearest by position")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  cmd->add_option("--baseline-neighbours", args.options.baseline_neighbours,
                  "... and the nearest in this many distance bands (0.5-1 "
                  "m, 1-2 m, ...), for parallax")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  cmd->add_option("--loop-neighbours", args.options.loop_neighbours,
                  "... and this many old photos of the same place (loops); "
                  "0 turns loop closing off")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  cmd->add_option("--max-registrations",
                  args.options.max_registrations_per_update,
                  "captures one photo's increment registers at most (the "
                  "rest of those a loop frees wait for the refinement); 0: "
                  "no limit")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  cmd->add_flag(
      "--single-model", [](int64_t) { args.options.multiple_models = false; },
      "one chain, as COLMAP's Mapper.multiple_models 0: photos that reach no "
      "point of the model wait instead of starting a component");
  cmd->add_option("--retire-below", args.options.retire_component_below,
                  "a component with fewer photos than this that stopped "
                  "growing is retired: its photos wait for another to reach "
                  "them")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--retire-after", args.options.retire_component_after,
                  "... once the site took this many photos since it grew")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--refine-intrinsics", args.options.refine_intrinsics,
                  "auto (uncalibrated cameras only), on or off")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "on", "off"}));
  cmd->add_option("--threads", args.options.threads, "worker threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  cmd->add_flag("--deterministic", args.options.deterministic,
                "fixed seeds and single-threaded solvers: identical output for "
                "identical input");
  cmd->add_flag("--dense", args.dense,
                "also grow the dense cloud (plane-sweep depth maps, fused) "
                "after every photo and write OUT/dense.ply");
  cmd->add_flag("--mesh", args.mesh,
                "with --dense, also the textured surface of the cloud "
                "(docs/mesh.md) as OUT/mesh.glb (site frame, z up)");
  cmd->add_flag("--mesh-check", args.mesh_check,
                "with --mesh, predict each key view from the surface "
                "textured from the others: ZNCC and covered share per view "
                "in OUT/mesh_check.csv");
  cmd->add_option("--dense-long-side", args.dense_options.long_side,
                  "dense working resolution, long side in px")
      ->capture_default_str()
      ->check(CLI::Range(100, 10000));
  cmd->add_option("--dense-new-coverage", args.dense_options.new_coverage_share,
                  "as arscout serve's: no sweep for a photo two held maps "
                  "already measure this share of (0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--dense-min-agreeing",
                  args.dense_options.consistency.min_agreeing_maps,
                  "fuse a depth once this many other depth maps agree with it")
      ->capture_default_str()
      ->check(CLI::Range(1, 8));
  cmd->add_option("--dense-free-space",
                  args.dense_options.consistency.free_space_margin,
                  "drop a depth that more depth maps see through (by this "
                  "share of their depth) than agree with it (0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--dense-sky-texture",
                  args.dense_options.sweep.sky_max_texture,
                  "give no depth to the smooth region joined to a photo's top "
                  "row (5 x 5 grey std below this, 0-255; 0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 255.0));
  cmd->add_option("--dense-min-angle",
                  args.dense_options.sweep.min_triangulation_deg,
                  "drop a depth that no neighbour sees at this triangulation "
                  "angle or more (degrees; 0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 30.0));
  cmd->add_option("--dense-weak-angle",
                  args.dense_options.consistency.weak_triangulation_deg,
                  "a depth that no neighbour sees at this triangulation angle "
                  "or more needs one more agreeing depth map (degrees; 0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 30.0));
  cmd->add_option("--dense-distinct-margin",
                  args.dense_options.consistency.distinct_margin,
                  "a depth whose ZNCC beats every other depth's by less than "
                  "this needs one more agreeing depth map (0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag_callback(
      "--dense-no-ground",
      [] { args.dense_options.sweep.ground_direction = false; },
      "sweep no planes parallel to the ground (by default they are "
      "swept once the model is in ENU and no scene plane found is "
      "already parallel to it)");
  cmd->add_flag("--cuda", args.dense_options.sweep.use_cuda,
                "sweep on the GPU when this build has the CUDA path and a "
                "device (else the CPU path runs)");
  cmd->add_option("--refine-budget", args.refine_budget_s,
                  "seconds of global adjustment between photos once the "
                  "model is past the inline size (the gap the service uses "
                  "while waiting for a photo); 0: only at the end")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--limit", args.limit, "add at most N new photos, then stop")
      ->check(CLI::PositiveNumber);
  cmd->add_option(
      "--save-state", args.save_state,
      "write the engine state here at the end (to continue with --resume)");
  cmd->add_option(
         "--resume", args.resume,
         "continue from a saved state; photos already in it are skipped")
      ->check(CLI::ExistingFile);
  cmd->callback([] { run_command([] { return run_reconstruct(args); }); });
}

const CommandRegistration reconstruct_command_registration(
    50, add_reconstruct_command);

}  // namespace
}  // namespace arscout::cli
