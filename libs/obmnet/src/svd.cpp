#include "obm/obmnet/svd.hpp"

#include "obm/core/errors.hpp"

namespace obm::obmnet {

namespace {
/// Non-negative weights (double) that sum to 1 per row. Rows whose weights all vanished fall back
/// to uniform weights (a plain Procrustes) instead of a zero H, whose solve would silently return
/// the identity.
torch::Tensor normalizedWeights(const torch::Tensor& weights, double eps) {
  auto w = weights.to(torch::kFloat64).clamp_min(0.0);
  const auto total = w.sum(1, /*keepdim=*/true);
  w = torch::where(total > eps, w, torch::ones_like(w));
  return w / w.sum(1, /*keepdim=*/true);
}
}  // namespace

RigidTransforms weightedProcrustes(const torch::Tensor& src, const torch::Tensor& tgt,
                                   const torch::Tensor& weights, double eps) {
  OBM_ASSERT(src.dim() == 3 && src.size(1) == 3 && src.sizes() == tgt.sizes(),
             "weightedProcrustes expects src and tgt B×3×N of equal shape");
  OBM_ASSERT(weights.dim() == 2 && weights.size(0) == src.size(0) && weights.size(1) == src.size(2),
             "weightedProcrustes expects weights B×N");
  const auto dtype = src.scalar_type();
  // The 3×3 problem is solved in double: negligible cost, and the SVD of a nearly degenerate H
  // (and its backward pass) is far better conditioned.
  const auto x = src.to(torch::kFloat64);
  const auto y = tgt.to(torch::kFloat64);
  const auto w = normalizedWeights(weights, eps);
  const auto wu = w.unsqueeze(1);      // B×1×N
  const auto x_bar = (x * wu).sum(2);  // B×3 weighted centroids
  const auto y_bar = (y * wu).sum(2);
  const auto xc = x - x_bar.unsqueeze(2);
  const auto yc = y - y_bar.unsqueeze(2);
  const auto H = torch::bmm(xc * wu, yc.transpose(1, 2));  // Σ w (x − x̄)(y − ȳ)ᵀ, B×3×3
  auto [U, S, Vh] = torch::linalg_svd(H, /*full_matrices=*/false);
  const auto V = Vh.transpose(1, 2);
  const auto Ut = U.transpose(1, 2);
  // diag(1, 1, det(V Uᵀ)) turns a reflection into the closest proper rotation.
  const auto det = torch::det(torch::bmm(V, Ut));
  auto diag = torch::ones({src.size(0), 3}, x.options());
  diag.select(1, 2).copy_(torch::where(det < 0, -torch::ones_like(det), torch::ones_like(det)));
  const auto R = torch::bmm(V * diag.unsqueeze(1), Ut);
  const auto t = y_bar - torch::bmm(R, x_bar.unsqueeze(2)).squeeze(2);
  return {R.to(dtype), t.to(dtype)};
}

RigidTransforms weightedProcrustesYaw(const torch::Tensor& src, const torch::Tensor& tgt,
                                      const torch::Tensor& weights, double eps) {
  OBM_ASSERT(src.dim() == 3 && src.size(1) == 3 && src.sizes() == tgt.sizes(),
             "weightedProcrustesYaw expects src and tgt B×3×N of equal shape");
  OBM_ASSERT(weights.dim() == 2 && weights.size(0) == src.size(0) && weights.size(1) == src.size(2),
             "weightedProcrustesYaw expects weights B×N");
  const auto dtype = src.scalar_type();
  const auto x = src.to(torch::kFloat64);
  const auto y = tgt.to(torch::kFloat64);
  const auto w = normalizedWeights(weights, eps);
  const auto wu = w.unsqueeze(1);
  const auto x_bar = (x * wu).sum(2);  // B×3
  const auto y_bar = (y * wu).sum(2);
  const auto a = x - x_bar.unsqueeze(2);
  const auto b = y - y_bar.unsqueeze(2);
  const auto ax = a.select(1, 0), ay = a.select(1, 1), bx = b.select(1, 0), by = b.select(1, 1);
  const auto s = (w * (ax * by - ay * bx)).sum(1);  // Σ w (a × b)_z
  const auto c = (w * (ax * bx + ay * by)).sum(1);  // Σ w a·b (in the plane)
  // atan2's gradient is 1/(s² + c²): bounded away from the degenerate pair (all points on z).
  const auto theta = torch::atan2(s, c + 1e-300);
  const auto ct = torch::cos(theta), st = torch::sin(theta);
  const auto zero = torch::zeros_like(ct), one = torch::ones_like(ct);
  const auto R = torch::stack({torch::stack({ct, -st, zero}, 1), torch::stack({st, ct, zero}, 1),
                               torch::stack({zero, zero, one}, 1)},
                              1);  // B×3×3
  const auto t = y_bar - torch::bmm(R, x_bar.unsqueeze(2)).squeeze(2);
  return {R.to(dtype), t.to(dtype)};
}

torch::Tensor transformPoints(const RigidTransforms& T, const torch::Tensor& points) {
  return torch::bmm(T.R, points) + T.t.unsqueeze(2);
}

RigidTransforms compose(const RigidTransforms& T_a_b, const RigidTransforms& T_b_c) {
  return {torch::bmm(T_a_b.R, T_b_c.R),
          torch::bmm(T_a_b.R, T_b_c.t.unsqueeze(2)).squeeze(2) + T_a_b.t};
}

RigidTransforms identityTransforms(int64_t batch, const torch::TensorOptions& options) {
  return {torch::eye(3, options).unsqueeze(0).repeat({batch, 1, 1}),
          torch::zeros({batch, 3}, options)};
}

Isometry3d toIsometry(const torch::Tensor& R, const torch::Tensor& t, int64_t i) {
  const auto Rd = R[i].to(torch::kFloat64).contiguous();
  const auto td = t[i].to(torch::kFloat64).contiguous();
  Eigen::Matrix3d Rm;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Rm(r, c) = Rd[r][c].item<double>();
  return makeIsometry(
      Rm, Eigen::Vector3d(td[0].item<double>(), td[1].item<double>(), td[2].item<double>()));
}

RigidTransforms fromIsometry(const Isometry3d& T) {
  // Row-major copies (Eigen stores column-major) as R·p expects.
  const Eigen::Matrix<float, 3, 3, Eigen::RowMajor> R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  return {torch::from_blob(const_cast<float*>(R.data()), {1, 3, 3}, torch::kFloat32).clone(),
          torch::from_blob(const_cast<float*>(t.data()), {1, 3}, torch::kFloat32).clone()};
}

}  // namespace obm::obmnet
