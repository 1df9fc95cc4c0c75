#include "top_view_png.hpp"

#include "obm/io/rgbd.hpp"

namespace obm::slam {

mapping::TopViewInfo writeTopViewPng(const mapping::OccupancyMap& map, const std::string& path,
                                     const mapping::TopViewOptions& options) {
  auto view = map.renderTopView(options);
  io::ColorImage img;
  img.width = view.info.width;
  img.height = view.info.height;
  img.rgb = std::move(view.rgb);
  io::writeColorPng(path, img);
  return view.info;
}

}  // namespace obm::slam
