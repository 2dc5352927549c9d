// The camera form: written and read back, and the one distortion rule
// every reader applies (docs/api.md).
#include "arscout/documents/camera.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "arscout/documents/document_error.h"

namespace arscout::documents {
namespace {

using Json = nlohmann::json;

Camera calibrated() {
  Camera c;
  c.width = 3072;
  c.height = 2048;
  c.fx = 2759.48;
  c.fy = 2764.16;
  c.cx = 1520.69;
  c.cy = 1006.81;
  c.k1 = -0.12;
  c.k2 = 0.05;
  c.p1 = 1e-4;
  c.p2 = -2e-4;
  c.k3 = 0.01;
  c.rms_px = 0.31;
  c.images_used = 14;
  return c;
}

void expect_same(const Camera& a, const Camera& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  for (auto [x, y] : {std::pair{a.fx, b.fx},
                      {a.fy, b.fy},
                      {a.cx, b.cx},
                      {a.cy, b.cy},
                      {a.k1, b.k1},
                      {a.k2, b.k2},
                      {a.p1, b.p1},
                      {a.p2, b.p2},
                      {a.k3, b.k3},
                      {a.rms_px, b.rms_px}})
    EXPECT_EQ(x, y);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.images_used, b.images_used);
}

TEST(CameraForm, RoundTripsThroughJsonText) {
  const Camera c = calibrated();
  const Json written = Json::parse(to_json(c).dump());
  EXPECT_EQ(written["distortion"].size(), 5u);
  EXPECT_EQ(validate_camera(written), "");
  expect_same(camera_from_json(written), c);
}

TEST(CameraForm, FitStatisticsOnlyForAFit) {
  Camera c = calibrated();
  c.images_used = 0;
  const Json written = to_json(c);
  EXPECT_FALSE(written.contains("rms_px"));
  EXPECT_FALSE(written.contains("images_used"));
  EXPECT_EQ(camera_from_json(written).rms_px, 0);
}

Json with_distortion(const Json& terms) {
  Json j = to_json(calibrated());
  if (terms.is_discarded())
    j.erase("distortion");
  else
    j["distortion"] = terms;
  return j;
}

TEST(CameraForm, MissingTermsAreZero) {
  for (const Json& terms :
       {Json(Json::value_t::discarded), Json(nullptr), Json::array()}) {
    const Camera c = camera_from_json(with_distortion(terms));
    EXPECT_FALSE(c.has_distortion()) << terms.dump();
  }
  const Camera two = camera_from_json(with_distortion({-0.2, 0.03}));
  EXPECT_EQ(two.k1, -0.2);
  EXPECT_EQ(two.k2, 0.03);
  EXPECT_EQ(two.p1, 0);
  EXPECT_EQ(two.k3, 0);
}

TEST(CameraForm, RationalTermsMustBeZero) {
  // OpenCV's eight terms with k4-k6 zero read as the five.
  const Camera eight =
      camera_from_json(with_distortion({-0.2, 0.03, 0, 0, 0.004, 0, 0, 0}));
  EXPECT_EQ(eight.k3, 0.004);
  // A non-zero k4-k6 would be dropped by a five-term model: refused.
  const Json rational = with_distortion({-0.2, 0.03, 0, 0, 0.004, 0.1, 0, 0});
  EXPECT_NE(validate_camera(rational).find("distortion[5] must be 0"),
            std::string::npos)
      << validate_camera(rational);
  EXPECT_THROW(camera_from_json(rational), DocumentError);
  // Nine terms, text, a number: not the form.
  for (const Json& bad :
       {Json::array({0, 0, 0, 0, 0, 0, 0, 0, 0}), Json("[0, 0]"), Json(0.1)})
    EXPECT_NE(validate_camera(with_distortion(bad)).find("distortion"),
              std::string::npos)
        << bad.dump();
}

TEST(CameraForm, ReaderRefusesWhatValidateRefuses) {
  Json j = to_json(calibrated());
  j["cx"] = 4000;  // outside the image
  EXPECT_NE(validate_camera(j), "");
  try {
    camera_from_json(j);
    FAIL() << "read a camera with cx outside the image";
  } catch (const DocumentError& e) {
    EXPECT_NE(std::string(e.what()).find("cx"), std::string::npos);
  }
}

}  // namespace
}  // namespace arscout::documents
