#pragma once
/// \file top_view_png.hpp
/// The occupancy map's top view as a PNG file (obm-map's map_topview.png, obm-octomap --png).
#include <string>

#include "obm/mapping/occupancy_map.hpp"

namespace obm::slam {

/// Renders the map's top view (OccupancyMap::renderTopView) and writes it as an RGB PNG
/// atomically. Throws ContractError for an empty map, IoError when the file cannot be written.
mapping::TopViewInfo writeTopViewPng(const mapping::OccupancyMap& map, const std::string& path,
                                     const mapping::TopViewOptions& options = {});

}  // namespace obm::slam
