// Incremental structure from motion for one site (the paper's sections
// 3.1-3.3): each capture is added on its own and updates the model at once,
// metric and in the site's ENU frame as soon as three registered captures
// carry GPS.
//
//   Reconstruction site(options);
//   AddResult r = site.add_capture({"c-1", jpeg_bytes, camera, "cam-a", fix});
//   Model m = site.model();
//   std::string state = site.serialize();   // ... later, in a new process:
//   Reconstruction resumed = Reconstruction::restore(state, options);
//
// A site's model may be made of several components (separately
// reconstructed parts: a walk with a break, scouts starting in different
// places). Photos that reach no component start one of their own, each is
// placed in ENU through its own fixes, and a photo that matches two merges
// them (docs/engine.md, "Components").
//
// Per capture: decode at the working resolution, undistort through the
// camera's look-up table, Harris corners with SIFT descriptors, matching
// against the capture's GPS neighbours and recent captures (never all
// pairs), geometric verification; with 3 captures the initial pair by the
// 5-point relative pose, then absolute pose (P3P in RANSAC) for each capture,
// triangulation, local bundle adjustment and a periodic global one with GPS
// priors, and a robust similarity to ENU.
//
// Not thread-safe: one site is driven by one thread at a time. Work inside a
// call uses up to `threads` cores.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"
#include "arscout/engine/model.h"
#include "arscout/engine/options.h"

namespace arscout::engine {

// What add_capture does to a photo before it touches the model: decoding
// at the working resolution, undistortion, features (the slowest part of a
// photo that does not depend on the model). prepare_capture is a pure
// function of the capture and the options and touches no Reconstruction, so
// a service runs it on another thread while the site's model is busy with
// earlier photos, and the photo's increment starts with its features ready.
// Opaque; copies share one immutable result.
class PreparedCapture {
 public:
  struct Impl;
  PreparedCapture();
  ~PreparedCapture();
  PreparedCapture(const PreparedCapture&);
  PreparedCapture& operator=(const PreparedCapture&);
  const std::string& capture_id() const;  // "" for a default-made one
  // Decode, undistortion and features, as add_capture would time them.
  StageTimings timings() const;

 private:
  friend PreparedCapture prepare_capture(const CaptureInput&,
                                         const ReconstructionOptions&);
  friend class Reconstruction;
  std::shared_ptr<const Impl> impl_;
};

// Throws std::invalid_argument as add_capture does for a photo that cannot
// be decoded or an invalid camera. `capture.image_bytes` is read, not kept.
PreparedCapture prepare_capture(const CaptureInput& capture,
                                const ReconstructionOptions& options);

class Reconstruction {
 public:
  explicit Reconstruction(ReconstructionOptions options = {});
  ~Reconstruction();
  Reconstruction(Reconstruction&&) noexcept;
  Reconstruction& operator=(Reconstruction&&) noexcept;

  // Adds one capture and updates the model. Throws std::invalid_argument
  // for a duplicate id, an image that cannot be decoded or an invalid
  // camera; the model is then unchanged.
  AddResult add_capture(const CaptureInput& capture);
  // The same with the photo prepared ahead (prepare_capture on the same
  // capture with this site's options): its features are used when they
  // were made for the camera this site holds for the capture (else the
  // photo is prepared again here), and `capture.image_bytes` is then not
  // read. The result is the same as add_capture(capture)'s; its timings
  // count only this call's stages.
  AddResult add_capture(const CaptureInput& capture,
                        const PreparedCapture& prepared);

  // Takes another site's reconstruction in (two sites that grew together,
  // docs/engine.md "Sites that grow together"): its captures, their
  // features, matches, poses and points join this one, moved from its ENU
  // frame into this one's, its components kept apart (renumbered after
  // this one's) until photos link them; the photos of each side nearest the
  // other are matched across at once (a bounded number), and the
  // components they link merge. `other` is left empty. Throws
  // std::invalid_argument, changing nothing, when either model has
  // registered captures but is not in ENU, or a capture is in both.
  AbsorbResult absorb(Reconstruction&& other);

  // Withdraws a capture: its observations go, and so do the points that
  // only it supported; the model is adjusted again. False if unknown.
  bool remove_capture(const std::string& id);

  // The global adjustment that add_capture leaves out once the model has
  // grown past `inline_global_ba_images`: all poses, points and refinable
  // intrinsics, with the GPS priors. `stop` is asked after every solver
  // iteration; when it says true the adjustment ends there and keeps the
  // progress made so far (each accepted iteration lowers the cost), so a
  // caller can run it between captures and give way to a new one. Does
  // nothing when nothing was registered since the last complete run.
  // Components that the photos registered since the last call link come
  // first: refine() merges them and returns. Then the captures that
  // add_capture left waiting beyond `max_registrations_per_update`:
  // refine() registers them, asking `stop` after each, and returns; the
  // adjustment is the next call's.
  RefineResult refine(const std::function<bool()>& stop = {});
  // True when refine() has work to do.
  bool refinement_due() const;
  // True when refine() has work and a merge of components or a loop
  // closure moved cameras since it last settled (a round met its tolerance,
  // or the bounded number of rounds on one model ran): the cameras may be
  // off by decimetres across the seam, and work that uses the poses (the
  // dense phase) should wait for the refinement.
  bool refinement_urgent() const;

  Model model() const;
  // The mean reprojection error over the whole model, working pixels (a
  // pass over every observation: for progress lines, not per increment).
  double mean_reprojection_px() const;
  std::vector<CaptureState> captures() const;
  int registered_count() const;

  // The whole state as bytes (features, matches, poses, points, the ENU
  // origin), so a later process continues without recomputing anything.
  // With `features_apart`, every capture's features (keypoints, descriptors
  // and colours: fixed once extracted, and most of the bytes) are left out:
  // a store keeps capture_features() of each capture once, and the state it
  // writes per increment stays a fraction of the site's size.
  std::string serialize(bool features_apart = false) const;
  // The captures whose features serialize(true) leaves out.
  std::vector<std::string> captures_with_features() const;
  // Whether `capture` is one of them (no list built: asked per new capture
  // of every increment).
  bool has_features(const std::string& capture) const;
  // One such capture's features as bytes; throws std::invalid_argument for
  // a capture without features here.
  std::string capture_features(const std::string& capture) const;
  // Throws std::runtime_error when the bytes are not a state this version
  // can read, or when features left out are not given by `features` (asked
  // by capture id for exactly those) or are not that capture's.
  static Reconstruction restore(
      const std::string& bytes, ReconstructionOptions options = {},
      const std::function<std::string(const std::string&)>& features = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::engine
