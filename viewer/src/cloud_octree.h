// The web viewer's level-of-detail cloud: an octree of a model version's
// point cloud (point_octree.h), built by the server on the first request
// for that version and kept in memory, so the browser streams the nodes it
// sees within its point budget instead of downloading the whole cloud
// (docs/viewer.md, "Level of detail").
//
//   GET /v1/sites/{id}/octree?cloud=dense|sparse        the hierarchy (JSON)
//   GET /v1/sites/{id}/octree/{version}/{node}.bin?cloud=  one node's points
//
// A node's bytes are its n points as n float32 x y z (ENU, little-endian)
// followed by n uchar r g b and n uchar support (ColoredPoint::support: 0
// for sparse points; the viewer hides fused points below
// kConfidentSupport by default).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>

#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "arscout/viewer/site_model.h"
#include "point_octree.h"

namespace arscout::viewer {

struct CloudOctree {
  std::string site;
  std::int64_t version = 0;
  std::string cloud;  // "dense" | "sparse": the cloud it holds
  // {"site", "version", "cloud", "points", "nodes": [{"name", "lo", "hi",
  // "points", "spacing", "children": [indices into nodes]}]}, the root
  // first; no nodes for a cloud without points.
  nlohmann::json hierarchy;
  std::map<std::string, std::string> node_bytes;  // by node name
  std::size_t byte_size = 0;  // of node_bytes in all, for the cache's bound
};

// Nodes far smaller than the 3D Tiles export's: the viewer draws a point
// budget's worth of them (0.5 million by default), and the finer they are,
// the more of the budget goes where the camera looks (a leaf of 50,000
// points would take a tenth of it).
inline constexpr OctreeOptions kViewerOctree{8000, 16};

// The octree of `points`, which are the `cloud` of `site`'s `version`.
CloudOctree build_cloud_octree(const std::vector<engine::ColoredPoint>& points,
                               const std::string& site, std::int64_t version,
                               const std::string& cloud,
                               const OctreeOptions& options = kViewerOctree);

// Octrees by (site, version, cloud), the least recently used dropped once
// they hold more than max_bytes in all (the last one is always kept).
// Thread-safe; a version that several requests want at once is built once.
class CloudOctreeCache {
 public:
  explicit CloudOctreeCache(std::size_t max_bytes = std::size_t{1} << 30)
      : max_bytes_(max_bytes) {}

  // The octree of the site's current model, its dense cloud when it has one
  // and `which` is kDense. Throws util::Error kNotFound without a model.
  std::shared_ptr<const CloudOctree> current(db::Store& store,
                                             const std::string& site,
                                             Cloud which);

  // A version built before, or null: versions are only built as current.
  std::shared_ptr<const CloudOctree> find(const std::string& site,
                                          std::int64_t version,
                                          const std::string& cloud);

 private:
  using Key = std::tuple<std::string, std::int64_t, std::string>;
  using Entry = std::shared_future<std::shared_ptr<const CloudOctree>>;

  std::shared_ptr<const CloudOctree> get_or_build(
      const Key& key, const std::function<CloudOctree()>& build);
  void evict_locked();

  const std::size_t max_bytes_;
  std::mutex mutex_;
  std::map<Key, Entry> entries_;
  std::list<Key> recency_;  // least recently used first
};

}  // namespace arscout::viewer
