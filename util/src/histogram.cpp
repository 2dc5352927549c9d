#include "arscout/util/histogram.h"

#include <sstream>

namespace arscout::util {

void Histogram::observe(double seconds) {
  std::lock_guard lock(mu_);
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (seconds <= kBuckets[i]) ++counts_[i];
  ++count_;
  sum_ += seconds;
}

std::string Histogram::render(const std::string& name,
                              const std::string& labels) const {
  const std::string sep = labels.empty() ? "" : ",";
  const std::string own = labels.empty() ? "" : "{" + labels + "}";
  std::ostringstream out;
  std::lock_guard lock(mu_);
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    out << name << "_bucket{" << labels << sep << "le=\"" << kBuckets[i]
        << "\"} " << counts_[i] << "\n";
  out << name << "_bucket{" << labels << sep << "le=\"+Inf\"} " << count_
      << "\n"
      << name << "_sum" << own << " " << sum_ << "\n"
      << name << "_count" << own << " " << count_ << "\n";
  return out.str();
}

std::uint64_t Histogram::count() const {
  std::lock_guard lock(mu_);
  return count_;
}

}  // namespace arscout::util
