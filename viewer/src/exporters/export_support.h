// What the exporters share: a file name from the model version, the
// geographic frame a geographic format needs, errors in util::Error's
// words.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "arscout/engine/geo.h"
#include "arscout/viewer/exporter.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer::formats {

// SITE-vVERSION-WHAT.EXTENSION ("s1-v7-dense.ply").
std::string versioned_name(const SiteModel& model, std::string_view what,
                           std::string_view extension);
// The name of a cloud format's file: the cloud's kind as WHAT, `suffix`
// after it ("-ecef").
std::string cloud_file_name(const SiteModel& model, Cloud cloud,
                            const Exporter& format,
                            std::string_view suffix = "");

// The model's ENU origin on WGS84. Throws util::Error kInvalidArgument when
// the model is not geo-registered: its frame is arbitrary, so there is no
// honest geography to give.
engine::Geodetic geographic_origin(const SiteModel& model);

// The cloud of the kind asked for; util::Error kNotFound when it is empty.
std::vector<engine::ColoredPoint> nonempty_cloud(db::Store& store,
                                                 const SiteModel& model,
                                                 Cloud cloud);

// Writes `bytes` to `out`.
void put(std::ostream& out, const std::string& bytes);

}  // namespace arscout::viewer::formats
