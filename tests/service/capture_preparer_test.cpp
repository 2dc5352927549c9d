// CapturePreparer: photos prepared on its thread in the order wanted,
// taken once, bounded in number, and failures left to the caller.
#include "capture_preparer.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace arscout::engine::service {
namespace {

// A textured 320 x 240 PNG (features to find), the same for every capture.
std::string photo_bytes() {
  static const std::string bytes = [] {
    cv::Mat image(240, 320, CV_8UC3);
    cv::theRNG().state = 7;
    cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
    std::vector<uchar> png;
    cv::imencode(".png", image, png);
    return std::string(png.begin(), png.end());
  }();
  return bytes;
}

CaptureInput input_of(const std::string& capture, std::string bytes) {
  CaptureInput input;
  input.id = capture;
  input.image_bytes = std::move(bytes);
  input.camera_id = "unnamed-320x240";
  return input;
}

ReconstructionOptions small() {
  ReconstructionOptions options;
  options.long_side = 320;
  options.max_features = 500;
  return options;
}

// Waits (up to a minute) until `done` holds.
template <typename F>
bool eventually(F done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(1);
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// Lets a test hold the preparer inside its read of one capture.
struct Gate {
  std::mutex mutex;
  std::condition_variable cv;
  bool open = false;
  std::atomic<int> waiting{0};
  void pass() {
    ++waiting;
    std::unique_lock lock(mutex);
    cv.wait(lock, [&] { return open; });
  }
  void release() {
    {
      std::lock_guard lock(mutex);
      open = true;
    }
    cv.notify_all();
  }
};

// Photo bytes for any capture, counting the reads; the read of "first"
// waits at `gate` when one is given.
CapturePreparer::ReadInput counted_reads(std::atomic<int>& reads,
                                         Gate* gate = nullptr) {
  return [&reads, gate](const std::string& capture) {
    ++reads;
    if (gate && capture == "first") gate->pass();
    return input_of(capture, photo_bytes());
  };
}

// Queues "first" and "second" and returns once "first" is being read.
void first_under_way(CapturePreparer& preparer, Gate& gate) {
  preparer.want("first");
  preparer.want("second");
  while (gate.waiting.load() == 0) std::this_thread::yield();
}

TEST(CapturePreparer, PreparesWhatIsWantedAndHandsItOverOnce) {
  std::atomic<int> reads{0};
  CapturePreparer preparer(counted_reads(reads), small());
  preparer.want("a");
  preparer.want("a");  // once
  ASSERT_TRUE(eventually([&] { return preparer.counts().prepared == 1; }));
  const auto taken = preparer.take("a");
  ASSERT_TRUE(taken.has_value());
  EXPECT_EQ(taken->photo.capture_id(), "a");
  EXPECT_EQ(taken->image_bytes, photo_bytes());
  EXPECT_GT(taken->photo.timings().features_s, 0);
  EXPECT_FALSE(preparer.take("a").has_value()) << "handed over once";
  EXPECT_FALSE(preparer.take("never-wanted").has_value());
  EXPECT_EQ(reads.load(), 1);
  EXPECT_EQ(preparer.counts().prepared, 1);
  EXPECT_EQ(preparer.counts().taken, 1);
}

TEST(CapturePreparer, OneStillQueuedIsLeftToTheCaller) {
  Gate gate;
  std::atomic<int> reads{0};
  CapturePreparer preparer(counted_reads(reads, &gate), small());
  first_under_way(preparer, gate);
  // "first" is being prepared, "second" waits its turn: the caller takes
  // it over rather than wait.
  EXPECT_FALSE(preparer.take("second").has_value());
  EXPECT_EQ(preparer.counts().missed, 1);
  gate.release();
  EXPECT_TRUE(preparer.take("first").has_value());
  EXPECT_EQ(preparer.counts().prepared, 1) << "second was not prepared";
}

TEST(CapturePreparer, HoldsNoMoreThanItsCapacity) {
  std::atomic<int> reads{0};
  CapturePreparer preparer(counted_reads(reads), small(),
                           /*capacity=*/1);
  preparer.want("a");
  preparer.want("b");
  ASSERT_TRUE(eventually([&] { return preparer.counts().prepared == 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(reads.load(), 1) << "b waits while a is held";
  ASSERT_TRUE(preparer.take("a").has_value());
  ASSERT_TRUE(eventually([&] { return preparer.counts().prepared == 2; }));
  EXPECT_TRUE(preparer.take("b").has_value());
}

TEST(CapturePreparer, ClearWaitsForTheWorkUnderWayAndDropsTheRest) {
  Gate gate;
  std::atomic<int> reads{0};
  CapturePreparer preparer(counted_reads(reads, &gate), small());
  first_under_way(preparer, gate);
  std::thread clearing([&] { preparer.clear(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  gate.release();
  clearing.join();  // returned only once "first" was done
  EXPECT_EQ(preparer.counts().prepared, 1);
  EXPECT_FALSE(preparer.take("first").has_value()) << "dropped";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(reads.load(), 1) << "second was dropped unread";
}

TEST(CapturePreparer, AFailureIsLeftForTheIncrementToReport) {
  CapturePreparer preparer(
      [&](const std::string& capture) {
        if (capture == "gone") throw std::invalid_argument("capture is gone");
        return input_of(capture, "not an image");
      },
      small());
  preparer.want("gone");
  preparer.want("broken");
  ASSERT_TRUE(eventually([&] { return preparer.counts().dropped == 2; }));
  EXPECT_FALSE(preparer.take("gone").has_value());
  EXPECT_FALSE(preparer.take("broken").has_value());
  EXPECT_EQ(preparer.counts().prepared, 0);
}

}  // namespace
}  // namespace arscout::engine::service
