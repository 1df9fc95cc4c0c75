#include "obm/obmnet/teacher.hpp"

#include <cmath>
#include <vector>

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

torch::Tensor estimateNormals(const torch::Tensor& points, int k) {
  OBM_ASSERT(points.dim() == 3 && points.size(1) == 3 && k >= 3 && points.size(2) >= k,
             "estimateNormals expects B×3×M points with M >= k >= 3");
  return pcaNormals(points, knnIndices(points, points, k));
}

namespace {

/// Batched exp of so(3): ω B×3 → B×3×3 (Rodrigues' formula; ω = 0 gives the identity).
torch::Tensor expSO3(const torch::Tensor& w) {
  const auto theta = w.norm(2, 1, true);  // B×1
  const auto k = w / theta.clamp_min(1e-12);
  const auto z = torch::zeros_like(k.select(1, 0));
  const auto K = torch::stack({z, -k.select(1, 2), k.select(1, 1),   //
                               k.select(1, 2), z, -k.select(1, 0),   //
                               -k.select(1, 1), k.select(1, 0), z},  //
                              1)
                     .view({-1, 3, 3});
  const auto s = theta.sin().view({-1, 1, 1});
  const auto c = (1.0 - theta.cos()).view({-1, 1, 1});
  return torch::eye(3, w.options()).unsqueeze(0) + s * K + c * torch::matmul(K, K);
}

}  // namespace

RigidTransforms icpRefine(const torch::Tensor& src, const torch::Tensor& tgt,
                          const RigidTransforms& T0, int iterations, double initial_max_distance,
                          double max_distance, const torch::Tensor& tgt_normals) {
  checkShapes(src, tgt, "icpRefine");
  OBM_ASSERT(iterations >= 0 && max_distance > 0 && initial_max_distance >= max_distance,
             "icpRefine: iterations >= 0, initial_max_distance >= max_distance > 0");
  const bool plane = tgt_normals.defined();
  OBM_ASSERT(!plane || tgt_normals.sizes() == tgt.sizes(),
             "icpRefine: tgt_normals must be B×3×M");
  torch::NoGradGuard ng;
  RigidTransforms T{T0.R.detach().clone(), T0.t.detach().clone()};
  for (int it = 0; it < iterations; ++it) {
    const auto moved = transformPoints(T, src);
    const auto nn = nearestTargets(moved, tgt);
    const double f = iterations > 1 ? static_cast<double>(it) / (iterations - 1) : 1.0;
    const double gate = initial_max_distance + f * (max_distance - initial_max_distance);
    const auto w = (nn.d < gate).to(src.scalar_type());  // B×N kept pairs
    RigidTransforms next;
    torch::Tensor ok;
    if (!plane) {
      // Solved from the original source, so the result is the whole T_target_source.
      next = weightedProcrustes(src, nn.q, w);
      // Fewer than three kept pairs do not determine a rotation.
      ok = w.sum(1) >= 3.0;
    } else {
      // r_i = n_i·(m_i − q_i) at the moved point m_i; with m_i → exp(ω) m_i + v,
      // ∂r_i/∂(ω, v) = (m_i × n_i, n_i). Normal equations A δ = −Σ w J r, per pair, in
      // double.
      const auto n =
          tgt_normals.gather(2, nn.idx.unsqueeze(1).expand({tgt.size(0), 3, nn.idx.size(1)}));
      const auto r = (n * (moved - nn.q)).sum(1);                                    // B×N
      const auto J =
          torch::cat({torch::cross(moved, n, 1), n}, 1).to(torch::kFloat64);  // B×6×N
      const auto wd = w.to(torch::kFloat64);
      const auto Jw = J * wd.unsqueeze(1);
      const auto A = torch::matmul(Jw, J.transpose(1, 2)) +
                     1e-9 * torch::eye(6, J.options()).unsqueeze(0);                 // B×6×6
      const auto b = -torch::matmul(Jw, r.to(torch::kFloat64).unsqueeze(2));         // B×6×1
      const auto delta = torch::linalg_solve(A, b).squeeze(2).to(src.scalar_type());  // B×6
      const auto dR = expSO3(delta.narrow(1, 0, 3));
      next.R = torch::matmul(dR, T.R);
      next.t = torch::matmul(dR, T.t.unsqueeze(2)).squeeze(2) + delta.narrow(1, 3, 3);
      // Six parameters: fewer than six kept pairs leave the step undetermined.
      ok = (w.sum(1) >= 6.0) & torch::isfinite(delta).all(1);
    }
    T.R = torch::where(ok.view({-1, 1, 1}), next.R, T.R);
    T.t = torch::where(ok.view({-1, 1}), next.t, T.t);
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
  checkShapes(src, tgt, "teacherLabels");
  torch::NoGradGuard ng;
  const int64_t B = src.size(0);
  std::vector<RigidTransforms> bases{{T_net.R.detach(), T_net.t.detach()}};
  if (p.from_identity) bases.push_back(identityTransforms(B, src.options()));
  std::vector<RigidTransforms> starts = bases;
  if (p.start_rotation_deg > 0.0) {
    const double a = p.start_rotation_deg * M_PI / 180.0;
    for (const auto& base : bases) {
      // Turned about the moved source's centroid c: R' = Ra R, t' = Ra (t − c) + c.
      const auto c = transformPoints(base, src).mean(2);  // B×3
      for (int axis = 0; axis < 3; ++axis)
        for (const double sign : {1.0, -1.0}) {
          auto w = torch::zeros({B, 3}, src.options());
          w.select(1, axis).fill_(sign * a);
          const auto Ra = expSO3(w);
          starts.push_back({torch::matmul(Ra, base.R),
                            torch::matmul(Ra, (base.t - c).unsqueeze(2)).squeeze(2) + c});
        }
    }
  }
  const torch::Tensor normals =
      p.point_to_plane ? estimateNormals(tgt, p.normal_neighbours) : torch::Tensor();
  RigidTransforms T;
  torch::Tensor count;  // B: labelled points of the best start so far
  for (const auto& s : starts) {
    const auto Ts = icpRefine(src, tgt, s, p.icp_iterations, p.initial_max_distance,
                              p.max_distance, normals);
    const auto ls = correspondenceLabels(src, tgt, Ts, p.match_radius);
    const auto cs = (ls >= 0).sum(1);
    if (!count.defined()) {
      T = Ts;
      labels = ls;
      count = cs;
      continue;
    }
    // Strictly more labelled points replaces: the earlier start wins ties.
    const auto better = cs > count;
    T.R = torch::where(better.view({-1, 1, 1}), Ts.R, T.R);
    T.t = torch::where(better.view({-1, 1}), Ts.t, T.t);
    labels = torch::where(better.view({-1, 1}), ls, labels);
    count = torch::where(better, cs, count);
  }
  if (p.min_fitness > 0.0) {
    const auto weak = count.to(torch::kFloat64) < p.min_fitness * static_cast<double>(src.size(2));
    labels = torch::where(weak.view({-1, 1}), torch::full_like(labels, -1), labels);
  }
  return T;
}

}  // namespace obm::obmnet
