#include "obm/sim/lidar.hpp"

#include <algorithm>
#include <cmath>

#include "embree_scene.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/random.hpp"
#include "obm/core/parallel.hpp"

namespace obm::sim {

// ---------------------------------------------------------------------------------------------
// Parameters

LidarParams LidarParams::load(const ConfigNode& n) {
  LidarParams p;
  n.checkKeys({"type",
               "layout",
               "elevations_deg",
               "rings",
               "max_elevation_deg",
               "min_elevation_deg",
               "azimuth_step_deg",
               "rate_hz",
               "min_range",
               "max_range",
               "noise",
               "range_noise_sigma",
               "dropout_probability",
               "grazing_start_deg",
               "grazing_full_deg",
               "range_at_10pct",
               "intensity_noise_sigma",
               "material_effects",
               "motion_distortion",
               "threads"});
  n.get("layout", p.layout);
  n.get("elevations_deg", p.elevations_deg);
  n.get("rings", p.rings);
  n.get("max_elevation_deg", p.max_elevation_deg);
  n.get("min_elevation_deg", p.min_elevation_deg);
  n.get("azimuth_step_deg", p.azimuth_step_deg);
  n.get("rate_hz", p.rate_hz);
  n.get("min_range", p.min_range);
  n.get("max_range", p.max_range);
  n.get("noise", p.noise);
  n.get("range_noise_sigma", p.range_noise_sigma);
  n.get("dropout_probability", p.dropout_probability);
  n.get("grazing_start_deg", p.grazing_start_deg);
  n.get("grazing_full_deg", p.grazing_full_deg);
  n.get("range_at_10pct", p.range_at_10pct);
  n.get("intensity_noise_sigma", p.intensity_noise_sigma);
  n.get("material_effects", p.material_effects);
  n.get("motion_distortion", p.motion_distortion);
  n.get("threads", p.threads);
  if (n.has("layout") && p.layout == "custom" && !n.has("elevations_deg"))
    throw ConfigError(n.where("elevations_deg") + ": required when layout is 'custom'");
  p.validate(n.where());
  return p;
}

void LidarParams::validate(const std::string& where) const {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(where + (where.empty() ? "" : ".") + key + ": " + what);
  };
  if (layout != "hdl64" && layout != "vlp16" && layout != "uniform" && layout != "custom")
    fail("layout", "unknown layout '" + layout + "' (expected hdl64, vlp16, uniform or custom)");
  if (layout == "custom" && elevations_deg.empty())
    fail("elevations_deg", "the sensor has zero rays: no ring elevations given");
  if (layout == "uniform" && rings <= 0)
    fail("rings", "the sensor has zero rays: rings must be positive, got " + std::to_string(rings));
  if (!(azimuth_step_deg > 0.0) || azimuth_step_deg > 360.0)
    fail("azimuth_step_deg", "the sensor has zero rays: azimuth step must be in (0, 360]");
  if (!(rate_hz > 0.0)) fail("rate_hz", "must be positive");
  if (!(max_range > 0.0)) fail("max_range", "must be positive");
  if (!(min_range >= 0.0) || min_range >= max_range) fail("min_range", "must be in [0, max_range)");
  if (range_noise_sigma < 0.0) fail("range_noise_sigma", "must be ≥ 0");
  if (dropout_probability < 0.0 || dropout_probability > 1.0)
    fail("dropout_probability", "must be in [0, 1]");
  if (!(grazing_full_deg > grazing_start_deg))
    fail("grazing_full_deg", "must exceed grazing_start_deg");
  for (double e : elevations_deg)
    if (std::fabs(e) >= 90.0) fail("elevations_deg", "elevations must be in (−90°, 90°)");
}

std::vector<double> LidarParams::ringElevations() const {
  std::vector<double> deg;
  if (layout == "hdl64") {
    // Velodyne HDL-64E S2: upper block of 32 lasers from +2.0° in 1/3° steps (to −8.33°), lower
    // block of 32 lasers evenly down to −24.9° (≈ 1/2° steps), 26.9° vertical field of view.
    for (int i = 0; i < 32; ++i) deg.push_back(2.0 - i / 3.0);
    const double lo0 = -8.83, lo1 = -24.9;
    for (int i = 0; i < 32; ++i) deg.push_back(lo0 + (lo1 - lo0) * i / 31.0);
  } else if (layout == "vlp16") {
    for (int i = 0; i < 16; ++i) deg.push_back(15.0 - 2.0 * i);
  } else if (layout == "uniform") {
    for (int i = 0; i < rings; ++i)
      deg.push_back(rings == 1 ? max_elevation_deg
                               : max_elevation_deg +
                                     (min_elevation_deg - max_elevation_deg) * i / (rings - 1));
  } else {
    deg = elevations_deg;
  }
  std::vector<double> rad(deg.size());
  for (std::size_t i = 0; i < deg.size(); ++i) rad[i] = deg[i] * kDegToRad;
  return rad;
}

std::size_t LidarParams::columns() const {
  if (!(azimuth_step_deg > 0.0)) return 0;
  return static_cast<std::size_t>(std::max(1.0, std::round(360.0 / azimuth_step_deg)));
}

std::size_t LidarParams::raysPerSweep() const {
  return ringElevations().size() * columns();
}

// ---------------------------------------------------------------------------------------------
// Simulator

LidarSimulator::LidarSimulator(LidarParams params) : params_(std::move(params)) {
  params_.validate();
  const auto el = params_.ringElevations();
  if (el.empty()) throw ConfigError("lidar: the sensor has zero rays (no rings)");
  for (double e : el) {
    cos_el_.push_back(static_cast<float>(std::cos(e)));
    sin_el_.push_back(static_cast<float>(std::sin(e)));
  }
  const std::size_t nc = params_.columns();
  for (std::size_t c = 0; c < nc; ++c) {
    const double a = azimuth(c);
    cos_az_.push_back(static_cast<float>(std::cos(a)));
    sin_az_.push_back(static_cast<float>(std::sin(a)));
  }
}

double LidarSimulator::azimuth(std::size_t column) const {
  // Clockwise from behind: +180° at the first column, 0° (forward) at the middle.
  const double step = 2.0 * M_PI / static_cast<double>(params_.columns());
  return M_PI - (static_cast<double>(column) + 0.5) * step;
}

double LidarSimulator::columnTimeOffset(std::size_t column) const {
  const double n = static_cast<double>(params_.columns());
  return ((static_cast<double>(column) + 0.5) / n - 0.5) * params_.sweepPeriod();
}

Eigen::Vector3f LidarSimulator::direction(std::size_t ring, std::size_t column) const {
  return {cos_el_[ring] * cos_az_[column], cos_el_[ring] * sin_az_[column], sin_el_[ring]};
}

LidarSweep LidarSimulator::simulate(const RaycastScene& scene,
                                    const Eigen::Isometry3d& T_world_sensor, double t,
                                    std::uint64_t seed) const {
  return simulate(
      scene, [&T_world_sensor](double) { return T_world_sensor; }, t, seed);
}

namespace {
struct ChunkOut {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;
  std::vector<std::uint16_t> ring, column;
  std::vector<float> time;
};

constexpr std::size_t kColumnsPerTask = 32;
constexpr int kMaxPassThrough = 3;
}  // namespace

LidarSweep LidarSimulator::simulate(const RaycastScene& scene, const PoseAtTime& pose, double t,
                                    std::uint64_t seed) const {
  const auto& S = scene.impl();
  const LidarParams& P = params_;
  const std::size_t nr = cos_el_.size(), nc = cos_az_.size();
  const std::size_t n_tasks = (nc + kColumnsPerTask - 1) / kColumnsPerTask;
  std::vector<ChunkOut> out(n_tasks);
  const Eigen::Isometry3d T_fixed = pose(t);

  const bool noisy = P.noise;
  const float sigma = static_cast<float>(P.range_noise_sigma);
  const double cos_start = std::cos(P.grazing_start_deg * kDegToRad);
  const double cos_full = std::cos(P.grazing_full_deg * kDegToRad);
  const double r10 = P.range_at_10pct;

  parallelFor(n_tasks, P.threads, [&](std::size_t task) {
    Rng rng(hashSeed(seed, 0x11da5, task));
    ChunkOut& o = out[task];
    const std::size_t c0 = task * kColumnsPerTask, c1 = std::min(nc, c0 + kColumnsPerTask);
    o.points.reserve((c1 - c0) * nr);
    o.intensity.reserve((c1 - c0) * nr);
    o.ring.reserve((c1 - c0) * nr);
    o.column.reserve((c1 - c0) * nr);
    o.time.reserve((c1 - c0) * nr);
    RayPacket16 pk;
    for (std::size_t c = c0; c < c1; ++c) {
      const float dt = static_cast<float>(columnTimeOffset(c));
      const Eigen::Isometry3d T = P.motion_distortion ? pose(t + dt) : T_fixed;
      const Eigen::Matrix3f R = T.linear().cast<float>();
      const Eigen::Vector3f o3 = T.translation().cast<float>();
      for (std::size_t r0 = 0; r0 < nr; r0 += 16) {
        pk.clear();
        const int lanes = static_cast<int>(std::min<std::size_t>(16, nr - r0));
        for (int i = 0; i < lanes; ++i) {
          const Eigen::Vector3f dw = R * direction(r0 + i, c);
          pk.set(i, o3.x(), o3.y(), o3.z(), dw.x(), dw.y(), dw.z(), static_cast<float>(P.min_range),
                 static_cast<float>(P.max_range));
        }
        intersectPacket(S, pk, false);
        for (int i = 0; i < lanes; ++i) {
          if (!pk.hit(i)) continue;
          float range = pk.rh.ray.tfar[i];
          unsigned prim = pk.rh.hit.primID[i];
          float cosi = pk.cosIncidence(i);
          Material mat = S.mesh.materials[prim];
          if (P.material_effects && noisy) {
            // Foliage is partly transparent: continue the ray behind the hit a few times.
            for (int k = 0; k < kMaxPassThrough; ++k) {
              const auto& mp = materialProperties(mat);
              if (!(mp.pass_through > 0.f) || rng.uniformf() >= mp.pass_through) break;
              RTCRayHit rh1;
              rh1.ray.org_x = pk.rh.ray.org_x[i];
              rh1.ray.org_y = pk.rh.ray.org_y[i];
              rh1.ray.org_z = pk.rh.ray.org_z[i];
              rh1.ray.dir_x = pk.rh.ray.dir_x[i];
              rh1.ray.dir_y = pk.rh.ray.dir_y[i];
              rh1.ray.dir_z = pk.rh.ray.dir_z[i];
              rh1.ray.tnear = range + 0.05f;
              rh1.ray.tfar = static_cast<float>(P.max_range);
              rh1.ray.time = 0.f;
              rh1.ray.mask = 0xFFFFFFFFu;
              rh1.ray.id = 0;
              rh1.ray.flags = 0;
              rh1.hit.geomID = RTC_INVALID_GEOMETRY_ID;
              rh1.hit.primID = RTC_INVALID_GEOMETRY_ID;
              rh1.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
              RTCIntersectContext ctx;
              rtcInitIntersectContext(&ctx);
              rtcIntersect1(S.scene, &ctx, &rh1);
              if (rh1.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                range = -1.f;
                break;
              }
              range = rh1.ray.tfar;
              prim = rh1.hit.primID;
              mat = S.mesh.materials[prim];
              const Eigen::Vector3f ng(rh1.hit.Ng_x, rh1.hit.Ng_y, rh1.hit.Ng_z);
              const Eigen::Vector3f d(rh1.ray.dir_x, rh1.ray.dir_y, rh1.ray.dir_z);
              const float nn = ng.norm();
              cosi = nn > 0.f ? std::fabs(ng.dot(d)) / nn : 0.f;
            }
            if (range < 0.f) continue;
          }
          const auto& mp = materialProperties(mat);
          if (noisy) {
            // Grazing incidence: the return weakens and is lost, linearly in cos between the
            // start and the full angle.
            if (cosi < cos_start) {
              const double p = cosi <= cos_full ? 1.0 : (cos_start - cosi) / (cos_start - cos_full);
              if (rng.uniform() < p) continue;
            }
            if (P.dropout_probability > 0.0 && rng.uniform() < P.dropout_probability) continue;
            if (P.material_effects && mp.dropout > 0.f && rng.uniformf() < mp.dropout) continue;
            // Received power ∝ ρ (0.3 + 0.7 cosθ) / r²; below the 10 %-at-R₁₀ threshold
            // nothing is detected.
            if (r10 > 0.0 &&
                mp.reflectivity * (0.3f + 0.7f * cosi) * (r10 / range) * (r10 / range) < 0.1)
              continue;
          }
          float meas = range;
          if (noisy && sigma > 0.f) meas += sigma * rng.normalFast();
          if (meas < P.min_range || meas > P.max_range) continue;
          float inten = mp.reflectivity * (0.5f + 0.5f * cosi) * 1.8f * std::exp(-range / 40.f);
          if (noisy && P.intensity_noise_sigma > 0.0)
            inten += static_cast<float>(P.intensity_noise_sigma) * rng.normalFast();
          inten = std::clamp(inten, 0.f, 1.f);
          o.points.push_back(direction(r0 + i, c) * meas);
          o.intensity.push_back(inten);
          o.ring.push_back(static_cast<std::uint16_t>(r0 + i));
          o.column.push_back(static_cast<std::uint16_t>(c));
          o.time.push_back(dt);
        }
      }
    }
  });

  LidarSweep sweep;
  sweep.rays = nr * nc;
  std::size_t total = 0;
  for (const auto& o : out) total += o.points.size();
  sweep.cloud.reserve(total);
  sweep.cloud.intensity.reserve(total);
  sweep.ring.reserve(total);
  sweep.column.reserve(total);
  sweep.time_offset.reserve(total);
  for (const auto& o : out) {
    sweep.cloud.points.insert(sweep.cloud.points.end(), o.points.begin(), o.points.end());
    sweep.cloud.intensity.insert(sweep.cloud.intensity.end(), o.intensity.begin(),
                                 o.intensity.end());
    sweep.ring.insert(sweep.ring.end(), o.ring.begin(), o.ring.end());
    sweep.column.insert(sweep.column.end(), o.column.begin(), o.column.end());
    sweep.time_offset.insert(sweep.time_offset.end(), o.time.begin(), o.time.end());
  }
  sweep.cloud.timestamp = t;
  sweep.cloud.frame_id = "lidar";
  return sweep;
}

}  // namespace obm::sim
