// The export cache (viewer/src/export_cache.h): one build per key however
// many requests arrive at once (hostile clients round two, row 5: 64
// concurrent LAS exports of one model each built their 19 MB file and held
// a request worker for it), failures not kept, least recently used files
// dropped past the size.
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "export_cache.h"

namespace arscout::viewer {
namespace {

ExportFile file_of(std::size_t bytes, char fill) {
  return {"f.las", "application/vnd.las", std::string(bytes, fill)};
}

TEST(ExportCache, ConcurrentRequestsForOneVersionShareOneBuild) {
  ExportCache cache(1 << 20);
  std::atomic<int> built{0};
  std::vector<std::shared_ptr<const ExportFile>> got(16);
  std::vector<std::thread> requests;
  for (std::size_t i = 0; i < got.size(); ++i)
    requests.emplace_back([&, i] {
      got[i] = cache.get("s/7/las", [&] {
        ++built;
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        return file_of(1000, 'a');
      });
    });
  for (std::thread& t : requests) t.join();
  EXPECT_EQ(built, 1);
  for (const auto& file : got) EXPECT_EQ(file.get(), got[0].get());
  EXPECT_EQ(cache.builds(), 1);
  EXPECT_EQ(cache.hits(), 15);
  EXPECT_EQ(cache.bytes(), 1000u);
  // Another version is another file.
  cache.get("s/8/las", [&] { return file_of(500, 'b'); });
  EXPECT_EQ(cache.builds(), 2);
}

TEST(ExportCache, AFailedBuildReachesItsWaitersAndIsNotKept) {
  ExportCache cache(1 << 20);
  EXPECT_THROW(cache.get("k",
                         []() -> ExportFile {
                           throw std::runtime_error("no model yet");
                         }),
               std::runtime_error);
  EXPECT_EQ(cache.get("k", [] { return file_of(10, 'c'); })->bytes,
            std::string(10, 'c'));
  EXPECT_EQ(cache.builds(), 2);
}

TEST(ExportCache, TheLeastRecentlyUsedGoPastTheSize) {
  ExportCache cache(2500);
  cache.get("a", [] { return file_of(1000, 'a'); });
  cache.get("b", [] { return file_of(1000, 'b'); });
  cache.get("a", [] { return file_of(1000, 'x'); });  // a is used again
  cache.get("c", [] { return file_of(1000, 'c'); });  // b goes
  EXPECT_EQ(cache.bytes(), 2000u);
  EXPECT_EQ(cache.get("a", [] { return file_of(1000, 'x'); })->bytes[0], 'a');
  EXPECT_EQ(cache.get("b", [] { return file_of(1000, 'y'); })->bytes[0], 'y');
  // A file larger than the whole cache is sent and not kept.
  const auto huge = cache.get("h", [] { return file_of(5000, 'h'); });
  EXPECT_EQ(huge->bytes.size(), 5000u);
  EXPECT_LE(cache.bytes(), 2500u);
}

}  // namespace
}  // namespace arscout::viewer
