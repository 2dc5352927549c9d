#include "cloud_octree.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <iterator>

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;

// n float32 x y z, then n uchar r g b, then n uchar support: what the
// browser puts in its position, colour and support buffers as they are.
std::string node_bytes(const std::vector<engine::ColoredPoint>& points,
                       const OctreeNode& node) {
  const std::size_t n = node.points.size();
  std::string bytes(n * 16, '\0');
  char* xyz = bytes.data();
  char* rgb = bytes.data() + n * 12;
  char* support = bytes.data() + n * 15;
  for (std::uint32_t i : node.points) {
    const engine::ColoredPoint& p = points[i];
    const float v[3] = {p.x, p.y, p.z};
    std::memcpy(xyz, v, sizeof v);  // little-endian hosts only (x86, ARM)
    xyz += sizeof v;
    *rgb++ = static_cast<char>(p.r);
    *rgb++ = static_cast<char>(p.g);
    *rgb++ = static_cast<char>(p.b);
    *support++ = static_cast<char>(p.support);
  }
  return bytes;
}

Json node_json(const OctreeNode& node) {
  return {{"name", node.name},       {"lo", node.box.lo},
          {"hi", node.box.hi},       {"points", node.points.size()},
          {"spacing", node.spacing}, {"children", node.children}};
}

}  // namespace

CloudOctree build_cloud_octree(const std::vector<engine::ColoredPoint>& points,
                               const std::string& site, std::int64_t version,
                               const std::string& cloud,
                               const OctreeOptions& options) {
  CloudOctree octree{site, version, cloud, {}, {}, 0};
  Json nodes = Json::array();
  if (!points.empty()) {
    const std::vector<OctreeNode> tree = build_point_octree(points, options);
    for (const OctreeNode& node : tree) {
      nodes.push_back(node_json(node));
      const auto added =
          octree.node_bytes.emplace(node.name, node_bytes(points, node));
      octree.byte_size += added.first->second.size();
    }
  }
  octree.hierarchy = {{"site", site},
                      {"version", version},
                      {"cloud", cloud},
                      {"points", points.size()},
                      {"nodes", std::move(nodes)}};
  return octree;
}

std::shared_ptr<const CloudOctree> CloudOctreeCache::current(
    db::Store& store, const std::string& site, Cloud which) {
  const SiteModel model = load_site_model(store, site);
  const std::string cloud = cloud_name(model, which);
  return get_or_build({site, model.version, cloud}, [&] {
    return build_cloud_octree(load_cloud(store, model, which), site,
                              model.version, cloud);
  });
}

std::shared_ptr<const CloudOctree> CloudOctreeCache::find(
    const std::string& site, std::int64_t version, const std::string& cloud) {
  Entry entry;
  {
    std::lock_guard lock(mutex_);
    const auto it = entries_.find({site, version, cloud});
    if (it == entries_.end()) return nullptr;
    entry = it->second;
  }
  try {
    return entry.get();
  } catch (const std::exception&) {
    return nullptr;  // its build failed; the builder's request reported it
  }
}

std::shared_ptr<const CloudOctree> CloudOctreeCache::get_or_build(
    const Key& key, const std::function<CloudOctree()>& build) {
  std::promise<std::shared_ptr<const CloudOctree>> promise;
  Entry entry;
  bool builder = false;
  {
    std::lock_guard lock(mutex_);
    recency_.remove(key);
    recency_.push_back(key);
    auto it = entries_.find(key);
    if (it == entries_.end()) {
      it = entries_.emplace(key, promise.get_future().share()).first;
      builder = true;
    }
    entry = it->second;
  }
  if (!builder) return entry.get();
  try {
    promise.set_value(std::make_shared<const CloudOctree>(build()));
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    entries_.erase(key);
    recency_.remove(key);
    throw;
  }
  std::lock_guard lock(mutex_);
  evict_locked();
  return entry.get();
}

// Entries still being built count nothing and stay: their requesters wait
// on them.
void CloudOctreeCache::evict_locked() {
  const auto size_of = [](const Entry& entry) -> std::size_t {
    if (entry.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
      return 0;
    try {
      return entry.get()->byte_size;
    } catch (const std::exception&) {
      return 0;  // a failed build, erased by its builder
    }
  };
  std::size_t total = 0;
  for (const auto& [key, entry] : entries_) total += size_of(entry);
  for (auto it = recency_.begin();
       total > max_bytes_ && std::next(it) != recency_.end();) {
    const auto entry = entries_.find(*it);
    if (entry != entries_.end() && entry->second.wait_for(std::chrono::seconds(
                                       0)) != std::future_status::ready) {
      ++it;
      continue;
    }
    if (entry != entries_.end()) {
      total -= size_of(entry->second);
      entries_.erase(entry);
    }
    it = recency_.erase(it);
  }
}

}  // namespace arscout::viewer
