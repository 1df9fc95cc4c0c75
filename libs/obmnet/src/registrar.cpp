#include "obm/obmnet/registrar.hpp"

#include <torch/torch.h>

#include <mutex>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"
#include "obm/obmnet/data.hpp"
#include "obm/obmnet/model_io.hpp"

namespace obm {

struct ObmNetRegistrar::Impl {
  Options opt;
  obmnet::ModelMeta meta;
  ObmNet model{nullptr};
  mutable std::mutex mutex;  // the module is not re-entrant (eval generator, buffers)
};

ObmNetRegistrar::ObmNetRegistrar(const Options& options) : impl_(std::make_unique<Impl>()) {
  impl_->opt = options;
  impl_->model = obmnet::loadModel(options.model_path, &impl_->meta);
  if (impl_->opt.num_points <= 0) impl_->opt.num_points = impl_->meta.num_points;
  if (options.threads > 0) torch::set_num_threads(options.threads);
}

ObmNetRegistrar::~ObmNetRegistrar() = default;
ObmNetRegistrar::ObmNetRegistrar(ObmNetRegistrar&&) noexcept = default;
ObmNetRegistrar& ObmNetRegistrar::operator=(ObmNetRegistrar&&) noexcept = default;

int ObmNetRegistrar::numPoints() const {
  return impl_->opt.num_points;
}

std::string ObmNetRegistrar::describe() const {
  return impl_->opt.model_path + " (" + impl_->meta.description + ")\n" +
         impl_->model->config().toYaml();
}

namespace {
torch::Tensor toTensor(const PointCloud& c) {
  auto t = torch::empty({1, 3, static_cast<int64_t>(c.size())}, torch::kFloat32);
  auto a = t.accessor<float, 3>();
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int d = 0; d < 3; ++d) a[0][d][static_cast<int64_t>(i)] = c.points[i][d];
  return t;
}
}  // namespace

RegistrationResult ObmNetRegistrar::align(const PointCloud& source,
                                          const PointCloud& target) const {
  Timer timer;
  const auto& cfg = impl_->model->config();
  const std::size_t need = static_cast<std::size_t>(std::max(cfg.k1, cfg.k2));
  if (source.size() < need || target.size() < need)
    throw ContractError("ObmNetRegistrar::align: clouds need at least " + std::to_string(need) +
                        " points (source has " + std::to_string(source.size()) + ", target " +
                        std::to_string(target.size()) + ")");
  RegistrationResult r;
  std::mt19937_64 rng(impl_->opt.seed);
  const auto n = static_cast<std::size_t>(impl_->opt.num_points);
  r.source_sampled = randomSubset(source, n, rng, &r.source_indices);
  r.target_sampled = randomSubset(target, n, rng);
  const auto norm = obmnet::PairNormalization::compute(r.source_sampled, r.target_sampled,
                                                       impl_->meta.normalize_radius);
  PointCloud src = obmnet::neighbourMean(r.source_sampled, impl_->opt.denoise_neighbors);
  PointCloud tgt = obmnet::neighbourMean(r.target_sampled, impl_->opt.denoise_neighbors);
  norm.applySource(src);
  norm.applyTarget(tgt);
  ObmNetOutput o;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    torch::NoGradGuard ng;
    o = impl_->model->forward(toTensor(src), toTensor(tgt), false);
  }
  const auto R = o.R[0].to(torch::kFloat64).contiguous();
  const auto t = o.t[0].to(torch::kFloat64).contiguous();
  Eigen::Matrix3d Rm;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Rm(i, j) = R[i][j].item<double>();
  const Isometry3d T_hat =
      makeIsometry(orthonormalize(Rm),
                   Eigen::Vector3d(t[0].item<double>(), t[1].item<double>(), t[2].item<double>()));
  r.T_target_source = norm.denormalize(T_hat);
  r.alpha = o.alpha[0].item<double>();
  r.overlap = o.overlap[0].item<double>();
  const auto w = o.weights[0].contiguous();
  const auto m = o.membership[0].contiguous();
  r.inlier_weights.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  r.overlap_membership.assign(m.data_ptr<float>(), m.data_ptr<float>() + m.numel());
  r.runtime_ms = timer.ms();
  return r;
}

}  // namespace obm
