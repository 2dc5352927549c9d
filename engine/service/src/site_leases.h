// How several workers on one database share out the sites (docs/service.md,
// "Several workers"): a worker holds a lease "site/{id}" for every site it
// reconstructs, and a lease "worker/{name}" that says it is alive; a
// heartbeat renews them all. A worker claims at most its fair share of the
// sites, ceil(sites / live workers), so that two workers starting together
// split the sites instead of one taking them all; when a worker dies its
// leases expire and the others' share grows to cover its sites.
//
// Thread-compatible: the worker calls it from its heartbeat thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

class SiteLeases {
 public:
  SiteLeases(db::Store& store, std::string holder,
             std::chrono::milliseconds ttl);

  static std::string lease_name(const std::string& site) {
    return "site/" + site;
  }

  // Renews (or first takes) this worker's leases; returns the sites it
  // still holds. A site missing from the answer was taken by another
  // worker after this one failed to renew in time.
  std::set<std::string> renew();
  // Claims sites of `wanted` within this worker's fair share of
  // `total_sites`; returns the sites newly held.
  std::set<std::string> claim(const std::vector<std::string>& wanted,
                              std::size_t total_sites, std::size_t held_sites);
  // Frees every lease of this worker, so that others need not wait for
  // them to expire.
  void release();

  // The change seq up to which a site's committed engine state has folded
  // in its work (attrs.through_seq of /sites/{id}/engine; 0 when none).
  std::int64_t settled_through(const std::string& site);

 private:
  db::Store& store_;
  const std::string holder_;
  const std::chrono::milliseconds ttl_;
};

}  // namespace arscout::engine::service
