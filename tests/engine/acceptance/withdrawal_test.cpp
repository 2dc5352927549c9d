// Withdrawing a capture and adding it back, through the library, on the
// real fountain-P11 photos.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "arscout/engine/image_size.h"
#include "arscout/engine/reconstruction.h"
#include "model_eval.h"
#include "test_stores.h"

namespace arscout {
namespace {

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

engine::CaptureInput capture(const std::string& scene, const std::string& name,
                             const std::map<std::string, eval::GeoRow>& fixes) {
  engine::CaptureInput input;
  input.id = name;
  input.image_bytes = read_bytes(scene + "/images/" + name);
  const auto size = engine::read_image_size(input.image_bytes);
  input.camera =
      engine::read_k_matrix(scene + "/images/K.txt", size->width, size->height);
  input.camera_id = "K";
  const eval::GeoRow& row = fixes.at(name);
  input.gps = engine::GeoFix{row.lat, row.lon, row.alt, 2.12, 3.0};
  return input;
}

const engine::ModelImage* find(const engine::Model& model,
                               const std::string& id) {
  for (const auto& image : model.images) {
    if (image.id == id) return &image;
  }
  return nullptr;
}

Eigen::Quaterniond rotation(const engine::ModelImage& image) {
  return {image.qvec[0], image.qvec[1], image.qvec[2], image.qvec[3]};
}

TEST(Withdrawal, AddingACaptureBackGivesTheSameRegistration) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const auto fixes = eval::read_geo_csv(scene + "/gps.csv");
  engine::ReconstructionOptions options;
  options.deterministic = true;
  engine::Reconstruction site(options);
  for (const auto& [name, fix] : fixes)
    site.add_capture(capture(scene, name, fixes));
  ASSERT_EQ(site.registered_count(), 11);
  const engine::Model before = site.model();
  const engine::ModelImage original = *find(before, "0005.jpg");

  ASSERT_TRUE(site.remove_capture("0005.jpg"));
  EXPECT_FALSE(site.remove_capture("0005.jpg"));
  const engine::Model without = site.model();
  EXPECT_EQ(without.images.size(), 10u);
  EXPECT_EQ(find(without, "0005.jpg"), nullptr);
  for (const auto& point : without.points) {
    EXPECT_GE(point.track.size(), 2u) << "a point left with one observation";
  }

  const engine::AddResult again =
      site.add_capture(capture(scene, "0005.jpg", fixes));
  EXPECT_EQ(again.status, engine::CaptureStatus::kRegistered) << again.reason;
  const engine::Model after = site.model();
  const engine::ModelImage* readded = find(after, "0005.jpg");
  ASSERT_NE(readded, nullptr);
  // The same registration: the same place among the other cameras (the
  // whole model may settle a few millimetres differently against the GPS,
  // so compare after aligning the two models' camera centres).
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& image : after.images) {
    from.emplace_back(image.centre.data());
    to.emplace_back(find(before, image.id)->centre.data());
  }
  const eval::Similarity align = eval::fit_similarity(from, to);
  const Eigen::Vector3d c0(original.centre.data());
  const Eigen::Vector3d c1 =
      align.apply(Eigen::Vector3d(readded->centre.data()));
  EXPECT_LE((c1 - c0).norm(), 0.002) << "metres";
  const Eigen::Quaterniond turned(align.R);
  EXPECT_LE(rotation(original).angularDistance(rotation(*readded) *
                                               turned.conjugate()) *
                180 / M_PI,
            0.02);
}

}  // namespace
}  // namespace arscout
