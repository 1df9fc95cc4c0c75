// Uses the installed obmslam headers and libraries: composes two poses and checks the result.
#include <obm/config/config_node.hpp>
#include <obm/core/point_cloud.hpp>
#include <obm/core/se3.hpp>

#include <cstdio>

int main() {
  const obm::Isometry3d T_a_b = obm::makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0));
  obm::PointCloud pc;
  pc.points.emplace_back(0.f, 0.f, 0.f);
  pc.transform(T_a_b);
  const auto cfg = obm::ConfigNode::fromString("x: 3");
  const int x = cfg.required<int>("x");
  const bool ok = pc.points[0].x() == 1.f && x == 3;
  std::printf("consumer: %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
