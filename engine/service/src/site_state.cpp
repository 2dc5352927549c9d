// load_site_reconstruction (arscout/engine/service.h): the one reader of a
// site's stored engine state, for the engine service and the viewer.
#include <map>
#include <stdexcept>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/engine/service.h"
#include "state_parts.h"

namespace arscout::engine {

std::optional<Reconstruction> load_site_reconstruction(
    db::Store& store, const std::string& site, ReconstructionOptions options,
    std::set<std::string>* stored_features) {
  const std::string root = "/sites/" + site;
  // The state first: its features were committed with it, so any listing
  // taken after holds them (a later increment only adds more).
  const auto state = store.get(root + "/engine");
  std::map<std::string, std::string> features;  // capture -> blob
  for (const db::Document& doc : store.list_children(root + "/features")) {
    if (!doc.blobs.count("features")) continue;
    features[std::string(db::leaf_name(doc.path))] = doc.blobs.at("features");
  }
  if (stored_features) {
    stored_features->clear();
    for (const auto& [capture, blob] : features)
      stored_features->insert(capture);
  }
  if (!state) return std::nullopt;
  const std::optional<std::string> bytes =
      service::read_state_bytes(store, *state);
  if (!bytes) return std::nullopt;
  return Reconstruction::restore(
      *bytes, std::move(options), [&](const std::string& capture) {
        auto it = features.find(capture);
        if (it == features.end())
          throw std::runtime_error("the engine state of site " + site +
                                   " has no stored features of capture " +
                                   capture);
        return store.get_blob(it->second);
      });
}

}  // namespace arscout::engine
