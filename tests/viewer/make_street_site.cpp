// Writes a site whose model holds the synthetic street as its dense cloud
// (synthetic_street.h, write_street_site), for the viewer's level-of-detail
// and measurement browser test and its benchmark, which need clouds far
// larger than a test can reconstruct.
//   make_street_site DB_URL SITE POINTS [components]
// "components": cameras in two components and a site merged into it too.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "arscout/db/store.h"
#include "synthetic_street.h"

int main(int argc, char** argv) {
  const bool components = argc == 5 && std::string(argv[4]) == "components";
  if (argc != 4 && !components) {
    std::fprintf(stderr,
                 "usage: make_street_site DB_URL SITE POINTS [components]\n");
    return 2;
  }
  try {
    const std::size_t count = std::stoull(argv[3]);
    auto store = arscout::db::Store::open(argv[1]);
    street_cloud::write_street_site(
        *store, argv[2], street_cloud::synthetic_street(count), components);
    std::printf("site %s: %zu points\n", argv[2], count);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_street_site: %s\n", e.what());
    return 1;
  }
}
