#include "obm/mrpt_bridge/export.hpp"

#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CObservationPointCloud.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/opengl/CGridPlaneXY.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CPointCloudColoured.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/stock_objects.h>
#include <mrpt/poses/CPose3DInterpolator.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/system/datetime.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/mrpt_bridge/conversions.hpp"

namespace obm::mrpt_bridge {

namespace {

/// Runs `save(tmp)` on a temporary path beside `path` and renames it into place.
template <class F>
void saveAtomically(const std::string& path, const char* what, F&& save) {
  const std::string tmp = temporaryPathFor(path);
  bool ok = false;
  try {
    ok = save(tmp);
  } catch (const std::exception& e) {
    std::filesystem::remove(tmp);
    throw IoError(path + ": cannot write the " + what + " (" + e.what() + ")");
  }
  if (!ok) {
    std::filesystem::remove(tmp);
    throw IoError(path + ": cannot write the " + what);
  }
  commitTemporaryFile(tmp, path);
}

mrpt::Clock::time_point toTime(double t) {
  return mrpt::Clock::fromDouble(t);
}

}  // namespace

void writeSimpleMap(const std::string& path, const std::vector<ExportKeyframe>& keyframes,
                    const std::string& sensor_label) {
  mrpt::maps::CSimpleMap sm;
  for (const auto& kf : keyframes) {
    auto obs = mrpt::obs::CObservationPointCloud::Create();
    obs->sensorLabel = sensor_label;
    obs->timestamp = toTime(kf.timestamp);
    obs->sensorPose = mrpt::poses::CPose3D();
    auto pts = mrpt::maps::CSimplePointsMap::Create();
    *pts = toPointsMap(kf.cloud);
    obs->pointcloud = pts;
    auto sf = mrpt::obs::CSensoryFrame::Create();
    sf->insert(obs);
    auto pdf = mrpt::poses::CPose3DPDFGaussian::Create(
        toPose3DPDFGaussian(kf.T_world_sensor, kf.information));
    sm.insert(pdf, sf);
  }
  saveAtomically(path, "simple map", [&](const std::string& tmp) { return sm.saveToFile(tmp); });
}

std::vector<SimpleMapEntry> readSimpleMap(const std::string& path) {
  if (!std::filesystem::exists(path)) throw IoError(path + ": no such file");
  mrpt::maps::CSimpleMap sm;
  bool ok = false;
  try {
    ok = sm.loadFromFile(path);
  } catch (const std::exception& e) {
    throw FormatError(path, 0, std::string("not an MRPT simple map (") + e.what() + ")");
  }
  if (!ok) throw FormatError(path, 0, "not an MRPT simple map");
  std::vector<SimpleMapEntry> out;
  for (std::size_t i = 0; i < sm.size(); ++i) {
    const auto [pdf, sf] = sm.get(i);
    SimpleMapEntry kf;
    mrpt::poses::CPose3D mean;
    pdf->getMean(mean);
    kf.T_world_sensor = fromCPose3D(mean);
    if (const auto* g = dynamic_cast<const mrpt::poses::CPose3DPDFGaussian*>(pdf.get()))
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) kf.covariance(r, c) = g->cov(r, c);
    if (sf) {
      for (const auto& o : *sf) {
        if (const auto* pc = dynamic_cast<const mrpt::obs::CObservationPointCloud*>(o.get());
            pc != nullptr && pc->pointcloud) {
          kf.cloud = toPointCloud(*pc->pointcloud);
          kf.timestamp = mrpt::Clock::toDouble(pc->timestamp);
          break;
        }
      }
    }
    out.push_back(std::move(kf));
  }
  return out;
}

void writePoseInterpolatorText(const std::string& path, const std::vector<double>& stamps,
                               const std::vector<Isometry3d>& poses) {
  if (stamps.size() != poses.size())
    throw ContractError("writePoseInterpolatorText: " + std::to_string(stamps.size()) +
                        " stamps for " + std::to_string(poses.size()) + " poses");
  mrpt::poses::CPose3DInterpolator interp;
  for (std::size_t i = 0; i < poses.size(); ++i)
    interp.insert(toTime(stamps[i]), toCPose3D(poses[i]).asTPose());
  saveAtomically(path, "trajectory",
                 [&](const std::string& tmp) { return interp.saveToTextFile(tmp); });
}

void write3DScene(const std::string& path, const SceneContent& c) {
  mrpt::opengl::COpenGLScene scene;
  // Ground grid around the trajectory, 10 m cells.
  double x0 = -10, x1 = 10, y0 = -10, y1 = 10;
  for (const auto& T : c.trajectory) {
    x0 = std::min(x0, T.translation().x() - 10);
    x1 = std::max(x1, T.translation().x() + 10);
    y0 = std::min(y0, T.translation().y() - 10);
    y1 = std::max(y1, T.translation().y() + 10);
  }
  auto grid = mrpt::opengl::CGridPlaneXY::Create(static_cast<float>(x0), static_cast<float>(x1),
                                                  static_cast<float>(y0), static_cast<float>(y1),
                                                  0.0f, 10.0f);
  grid->setColor_u8(mrpt::img::TColor(200, 200, 200));
  scene.insert(grid);
  scene.insert(mrpt::opengl::stock_objects::CornerXYZ(2.0f));

  if (!c.map_points.empty()) {
    auto cloud = mrpt::opengl::CPointCloudColoured::Create();
    float zmin = 1e30f, zmax = -1e30f;
    for (const auto& p : c.map_points.points) {
      zmin = std::min(zmin, p.z());
      zmax = std::max(zmax, p.z());
    }
    const float span = std::max(zmax - zmin, 1e-3f);
    for (const auto& p : c.map_points.points) {
      const float f = (p.z() - zmin) / span;  // height: blue (low) → yellow (high)
      cloud->push_back(p.x(), p.y(), p.z(), f, f, 1.0f - f);
    }
    cloud->setPointSize(2.0f);
    scene.insert(cloud);
  }
  auto polyline = [&](const std::vector<Isometry3d>& poses, mrpt::img::TColor color) {
    if (poses.size() < 2) return;
    auto lines = mrpt::opengl::CSetOfLines::Create();
    for (std::size_t i = 1; i < poses.size(); ++i) {
      const auto& a = poses[i - 1].translation();
      const auto& b = poses[i].translation();
      lines->appendLine(a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    }
    lines->setColor_u8(color);
    lines->setLineWidth(2.0f);
    scene.insert(lines);
  };
  polyline(c.ground_truth, mrpt::img::TColor(0, 160, 0));
  polyline(c.trajectory, mrpt::img::TColor(0, 0, 255));
  if (!c.loops.empty()) {
    auto lines = mrpt::opengl::CSetOfLines::Create();
    for (const auto& [a, b] : c.loops) lines->appendLine(a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    lines->setColor_u8(mrpt::img::TColor(255, 0, 0));
    lines->setLineWidth(2.0f);
    scene.insert(lines);
  }
  for (const auto& T : c.keyframes) {
    auto axes = mrpt::opengl::stock_objects::CornerXYZSimple(0.8f, 1.0f);
    axes->setPose(toCPose3D(T));
    scene.insert(axes);
  }
  saveAtomically(path, "3-D scene", [&](const std::string& tmp) { return scene.saveToFile(tmp); });
}

}  // namespace obm::mrpt_bridge
