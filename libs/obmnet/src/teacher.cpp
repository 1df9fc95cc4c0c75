#include "obm/obmnet/teacher.hpp"

#include "obm/core/errors.hpp"
#include "obm/obmnet/modules.hpp"

namespace obm::obmnet {

namespace {

/// Nearest target point of each moved source point: its index (B×N), the point (B×3×N) and the
/// distance (B×N).
struct Nearest {
  torch::Tensor idx, q, d;
};
Nearest nearestTargets(const torch::Tensor& moved, const torch::Tensor& tgt) {
  const auto idx = knnIndices(moved, tgt, 1).squeeze(2);  // B×N
  const auto q = tgt.gather(2, idx.unsqueeze(1).expand({tgt.size(0), 3, idx.size(1)}));
  return {idx, q, (moved - q).pow(2).sum(1).sqrt()};
}

void checkShapes(const torch::Tensor& src, const torch::Tensor& tgt, const char* what) {
  OBM_ASSERT(src.dim() == 3 && tgt.dim() == 3 && src.size(1) == 3 && tgt.size(1) == 3 &&
                 src.size(0) == tgt.size(0),
             std::string(what) + " expects src B×3×N and tgt B×3×M");
}

}  // namespace

RigidTransforms icpRefine(const torch::Tensor& src, const torch::Tensor& tgt,
                          const RigidTransforms& T0, int iterations, double initial_max_distance,
                          double max_distance) {
  checkShapes(src, tgt, "icpRefine");
  OBM_ASSERT(iterations >= 0 && max_distance > 0 && initial_max_distance >= max_distance,
             "icpRefine: iterations >= 0, initial_max_distance >= max_distance > 0");
  torch::NoGradGuard ng;
  RigidTransforms T{T0.R.detach().clone(), T0.t.detach().clone()};
  for (int it = 0; it < iterations; ++it) {
    const auto moved = transformPoints(T, src);
    const auto nn = nearestTargets(moved, tgt);
    const double f = iterations > 1 ? static_cast<double>(it) / (iterations - 1) : 1.0;
    const double gate = initial_max_distance + f * (max_distance - initial_max_distance);
    const auto w = (nn.d < gate).to(src.scalar_type());  // B×N kept pairs
    // Solved from the original source, so the result is the whole T_target_source.
    const auto step = weightedProcrustes(src, nn.q, w);
    // Fewer than three kept pairs do not determine a rotation: keep the previous transform.
    const auto ok = (w.sum(1) >= 3.0);
    T.R = torch::where(ok.view({-1, 1, 1}), step.R, T.R);
    T.t = torch::where(ok.view({-1, 1}), step.t, T.t);
  }
  return T;
}

torch::Tensor alignmentFitness(const torch::Tensor& src, const torch::Tensor& tgt,
                               const RigidTransforms& T, double radius) {
  return (correspondenceLabels(src, tgt, T, radius) >= 0).to(src.scalar_type()).mean(1);
}

torch::Tensor correspondenceLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                                   const RigidTransforms& T, double radius) {
  checkShapes(src, tgt, "correspondenceLabels");
  torch::NoGradGuard ng;
  const auto nn = nearestTargets(transformPoints(T, src), tgt);
  return torch::where(nn.d < radius, nn.idx, torch::full_like(nn.idx, -1));
}

RigidTransforms teacherLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                              const RigidTransforms& T_net, const TeacherParams& p,
                              torch::Tensor& labels) {
  torch::NoGradGuard ng;
  RigidTransforms T = icpRefine(src, tgt, T_net, p.icp_iterations, p.initial_max_distance,
                                p.max_distance);
  labels = correspondenceLabels(src, tgt, T, p.match_radius);
  if (p.from_identity) {
    const auto I = identityTransforms(src.size(0), src.options());
    const auto T_id = icpRefine(src, tgt, I, p.icp_iterations, p.initial_max_distance,
                                p.max_distance);
    const auto labels_id = correspondenceLabels(src, tgt, T_id, p.match_radius);
    // The fitness of a start is the share of points it labels.
    const auto better = (labels_id >= 0).sum(1) > (labels >= 0).sum(1);  // B
    T.R = torch::where(better.view({-1, 1, 1}), T_id.R, T.R);
    T.t = torch::where(better.view({-1, 1}), T_id.t, T.t);
    labels = torch::where(better.view({-1, 1}), labels_id, labels);
  }
  return T;
}

}  // namespace obm::obmnet
