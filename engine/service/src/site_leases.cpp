#include "site_leases.h"

#include <algorithm>

#include "arscout/db/store.h"
#include "arscout/documents/engine_state.h"

namespace arscout::engine::service {
namespace {

const std::string kSitePrefix = "site/";

std::string worker_lease(const std::string& holder) {
  return "worker/" + holder;
}

}  // namespace

SiteLeases::SiteLeases(db::Store& store, std::string holder,
                       std::chrono::milliseconds ttl)
    : store_(store), holder_(std::move(holder)), ttl_(ttl) {}

std::set<std::string> SiteLeases::renew() {
  // The worker lease is claimed rather than renewed: the first beat takes
  // it, and one lost while this worker was stalled is taken back.
  store_.claim_leases({worker_lease(holder_)}, holder_, ttl_, 1);
  std::set<std::string> sites;
  for (const std::string& name : store_.renew_leases(holder_, ttl_))
    if (name.rfind(kSitePrefix, 0) == 0)
      sites.insert(name.substr(kSitePrefix.size()));
  return sites;
}

std::set<std::string> SiteLeases::claim(const std::vector<std::string>& wanted,
                                        std::size_t total_sites,
                                        std::size_t held_sites) {
  std::size_t live = 0;
  for (const db::Lease& lease : store_.leases("worker/"))
    if (!lease.holder.empty() && lease.remaining.count() > 0) ++live;
  live = std::max<std::size_t>(live, 1);  // this worker, before its beat
  const std::size_t share = (total_sites + live - 1) / live;
  const std::size_t room = share > held_sites ? share - held_sites : 0;
  std::vector<std::string> names;
  for (const std::string& site : wanted) names.push_back(lease_name(site));
  std::set<std::string> taken;
  for (const std::string& name :
       store_.claim_leases(names, holder_, ttl_, room))
    taken.insert(name.substr(kSitePrefix.size()));
  return taken;
}

void SiteLeases::release() { store_.release_leases(holder_); }

std::int64_t SiteLeases::settled_through(const std::string& site) {
  auto doc = store_.get("/sites/" + site + "/engine");
  if (!doc) return 0;
  return documents::engine_state_from_json(doc->attrs).through_seq;
}

}  // namespace arscout::engine::service
