// Photos prepared ahead (prepare_capture) give the model add_capture gives
// when it prepares them itself; a prepared photo made for another capture
// or another camera is not used.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/engine/reconstruction.h"
#include "rendered_street.h"

namespace arscout::engine {
namespace {

using namespace street_fixture;

void expect_same_models(const Model& a, const Model& b) {
  ASSERT_EQ(a.images.size(), b.images.size());
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    EXPECT_EQ(a.images[i].id, b.images[i].id);
    EXPECT_EQ(a.images[i].qvec, b.images[i].qvec) << a.images[i].id;
    EXPECT_EQ(a.images[i].tvec, b.images[i].tvec) << a.images[i].id;
    EXPECT_EQ(a.images[i].keypoints, b.images[i].keypoints);
  }
}

TEST(PreparedCapture, GivesTheModelAddCaptureGivesAlone) {
  const std::vector<CaptureInput> captures = street_captures({320, 240});
  Reconstruction inline_site(street_options()), ahead_site(street_options());
  for (const CaptureInput& capture : captures) {
    const PreparedCapture prepared = prepare_capture(capture, street_options());
    EXPECT_EQ(prepared.capture_id(), capture.id);
    EXPECT_GT(prepared.timings().features_s, 0);
    CaptureInput without_bytes = capture;
    without_bytes.image_bytes.clear();  // must not be read
    const AddResult ahead = ahead_site.add_capture(without_bytes, prepared);
    const AddResult alone = inline_site.add_capture(capture);
    EXPECT_EQ(ahead.status, alone.status) << capture.id;
    EXPECT_EQ(ahead.features, alone.features);
    EXPECT_EQ(ahead.matched_pairs, alone.matched_pairs);
    // This call's own stages: the photo was decoded and described before.
    EXPECT_EQ(ahead.timings.features_s, 0);
    EXPECT_GT(alone.timings.features_s, 0);
  }
  EXPECT_GE(inline_site.registered_count(), 3);
  expect_same_models(inline_site.model(), ahead_site.model());
}

TEST(PreparedCapture, MadeForAnotherCaptureOrCameraIsNotUsed) {
  const std::vector<CaptureInput> captures = street_captures({320, 240});
  Reconstruction inline_site(street_options()), other_site(street_options());
  for (size_t i = 0; i < captures.size(); ++i) {
    const CaptureInput& capture = captures[i];
    // Odd photos: prepared as another capture; even ones: without their
    // camera (the guessed intrinsics, not the site's camera "street").
    CaptureInput prepared_as = capture;
    if (i % 2) {
      prepared_as.id = "someone-else";
    } else {
      prepared_as.camera.reset();
    }
    const PreparedCapture wrong =
        prepare_capture(prepared_as, street_options());
    const AddResult result = other_site.add_capture(capture, wrong);
    EXPECT_GT(result.timings.features_s, 0) << "prepared again here";
    inline_site.add_capture(capture);
  }
  expect_same_models(inline_site.model(), other_site.model());
}

TEST(PreparedCapture, RefusesWhatAddCaptureRefuses) {
  CaptureInput broken = street_captures({320, 240}).front();
  broken.image_bytes = "not an image";
  EXPECT_THROW(prepare_capture(broken, street_options()),
               std::invalid_argument);
  broken = street_captures({320, 240}).front();
  broken.camera->fx = -1;
  EXPECT_THROW(prepare_capture(broken, street_options()),
               std::invalid_argument);
}

}  // namespace
}  // namespace arscout::engine
