// Backend constructors, chosen by Store::open from the URL's scheme.
#pragma once

#include <memory>
#include <string>

#include "arscout/db/store.h"

namespace arscout::db::internal {

// path: the file after "sqlite:"; created when absent.
std::unique_ptr<Store> open_sqlite(const std::string& path,
                                   const OpenOptions& options);
// url: a libpq connection URI (postgresql://user@host:port/dbname?...).
std::unique_ptr<Store> open_postgres(const std::string& url,
                                     const OpenOptions& options);

}  // namespace arscout::db::internal
