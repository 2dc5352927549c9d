// Captures folded into one service increment (CaptureInput::more_follow):
// a small model's inline global adjustment that falls due while more
// captures follow waits for the increment's last, so an increment runs it
// at most once; one capture per call runs it whenever it is due.
#include <vector>

#include <gtest/gtest.h>

#include "arscout/engine/reconstruction.h"
#include "rendered_street.h"

namespace arscout::engine {
namespace {

using namespace street_fixture;

// Global adjustments run by each add_capture of `captures`, each marked
// as followed by more captures of its increment or not.
std::vector<int> global_adjustments(const std::vector<CaptureInput>& captures,
                                    const std::vector<bool>& more_follow,
                                    Reconstruction& site) {
  std::vector<int> result;
  for (size_t i = 0; i < captures.size(); ++i) {
    CaptureInput input = captures[i];
    input.more_follow = more_follow[i];
    const AddResult added = site.add_capture(input);
    // The first two wait for a third to make the initial model.
    if (i >= 2) {
      EXPECT_EQ(added.status, CaptureStatus::kRegistered) << input.id;
    }
    result.push_back(added.global_adjustments);
  }
  return result;
}

TEST(Increment, AGlobalAdjustmentDueWhileMoreFollowWaitsForTheLast) {
  const std::vector<CaptureInput> captures = street_captures({320, 240});
  ASSERT_EQ(captures.size(), 5u);
  // The first three make the initial model; the fourth and fifth each grow
  // it by more than a tenth, so each is due one when it comes alone.
  Reconstruction alone(street_options()), folded(street_options());
  const std::vector<int> one_by_one =
      global_adjustments(captures, {false, false, false, false, false}, alone);
  EXPECT_EQ(one_by_one[3], 1);
  EXPECT_EQ(one_by_one[4], 1);
  // The fourth and fifth folded into one increment: the fourth defers its
  // adjustment, the fifth (the increment's last) runs one for both.
  const std::vector<int> in_one =
      global_adjustments(captures, {false, false, false, true, false}, folded);
  EXPECT_EQ(in_one[3], 0);
  EXPECT_EQ(in_one[4], 1);
  EXPECT_EQ(alone.registered_count(), 5);
  EXPECT_EQ(folded.registered_count(), 5);
}

}  // namespace
}  // namespace arscout::engine
