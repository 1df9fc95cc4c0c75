#include "obm/sim/rgbd_camera.hpp"

#include <algorithm>
#include <cmath>

#include "embree_scene.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/random.hpp"
#include "obm/core/parallel.hpp"

namespace obm::sim {

namespace {

/// Grey-level noise of the colour image (σ ≈ 2 of 255, a Kinect-class sensor in room light).
constexpr float kColorNoise = 2.0f;

/// Smooth value noise in [0, 1] on a unit lattice: a hash per lattice point, blended trilinearly
/// with smoothstep weights. Deterministic, so a surface point has the same colour in every frame.
float valueNoise(const Eigen::Vector3f& x) {
  const Eigen::Vector3f f(std::floor(x.x()), std::floor(x.y()), std::floor(x.z()));
  const Eigen::Vector3f t = x - f;
  const Eigen::Vector3f w = t.array() * t.array() * (3.f - 2.f * t.array());
  auto lattice = [&](int dx, int dy, int dz) {
    std::uint64_t h = static_cast<std::uint64_t>(static_cast<std::int64_t>(f.x()) + dx) *
                      0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(static_cast<std::int64_t>(f.y()) + dy) * 0xC2B2AE3D27D4EB4Full;
    h ^= static_cast<std::uint64_t>(static_cast<std::int64_t>(f.z()) + dz) * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return static_cast<float>(h & 0xFFFFFF) / static_cast<float>(0xFFFFFF);
  };
  float v = 0.f;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx)
        v += (dx ? w.x() : 1.f - w.x()) * (dy ? w.y() : 1.f - w.y()) * (dz ? w.z() : 1.f - w.z()) *
             lattice(dx, dy, dz);
  return v;
}

/// Albedo texture of every surface at world point X: two octaves of value noise (7 cm and 25 cm
/// blobs), so walls, floors and furniture carry the texture an RGB-D tracker's photometric term
/// needs (real rooms: paint, wood grain, posters), in [0.55, 1].
float surfaceTexture(const Eigen::Vector3f& X) {
  return 0.55f + 0.3f * valueNoise(X / 0.07f) + 0.15f * valueNoise(X / 0.25f);
}

/// Lambertian shading under a fixed light from above plus ambient light: it depends on the
/// surface, not on the viewpoint, so a point keeps its brightness from frame to frame.
float lambertShade(const Eigen::Vector3f& normal) {
  static const Eigen::Vector3f light = Eigen::Vector3f(0.3f, 0.2f, 1.f).normalized();
  const float nn = normal.norm();
  if (!(nn > 0.f)) return 0.45f;
  return 0.45f + 0.55f * std::fabs(normal.dot(light)) / nn;
}

}  // namespace

RgbdParams RgbdParams::load(const ConfigNode& n) {
  RgbdParams p;
  n.checkKeys({"type",
               "width",
               "height",
               "fx",
               "fy",
               "cx",
               "cy",
               "min_depth",
               "max_depth",
               "rate_hz",
               "noise",
               "axial_sigma_a",
               "axial_sigma_b",
               "axial_sigma_z0",
               "axial_sigma_angle",
               "lateral_sigma_px",
               "disparity_step_px",
               "baseline",
               "projector_shadow",
               "max_incidence_deg",
               "dropout_probability",
               "color",
               "threads"});
  n.get("width", p.width);
  n.get("height", p.height);
  n.get("fx", p.fx);
  n.get("fy", p.fy);
  n.get("cx", p.cx);
  n.get("cy", p.cy);
  n.get("min_depth", p.min_depth);
  n.get("max_depth", p.max_depth);
  n.get("rate_hz", p.rate_hz);
  n.get("noise", p.noise);
  n.get("axial_sigma_a", p.axial_sigma_a);
  n.get("axial_sigma_b", p.axial_sigma_b);
  n.get("axial_sigma_z0", p.axial_sigma_z0);
  n.get("axial_sigma_angle", p.axial_sigma_angle);
  n.get("lateral_sigma_px", p.lateral_sigma_px);
  n.get("disparity_step_px", p.disparity_step_px);
  n.get("baseline", p.baseline);
  n.get("projector_shadow", p.projector_shadow);
  n.get("max_incidence_deg", p.max_incidence_deg);
  n.get("dropout_probability", p.dropout_probability);
  n.get("color", p.color);
  n.get("threads", p.threads);
  p.validate(n.where());
  return p;
}

void RgbdParams::validate(const std::string& where) const {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(where + (where.empty() ? "" : ".") + key + ": " + what);
  };
  if (width <= 0) fail("width", "the sensor has zero rays: width must be positive");
  if (height <= 0) fail("height", "the sensor has zero rays: height must be positive");
  if (!(fx > 0.0)) fail("fx", "must be positive");
  if (!(fy > 0.0)) fail("fy", "must be positive");
  if (!(rate_hz > 0.0)) fail("rate_hz", "must be positive");
  if (!(min_depth >= 0.0)) fail("min_depth", "must be ≥ 0");
  if (!(max_depth > min_depth)) fail("max_depth", "must exceed min_depth");
  if (disparity_step_px < 0.0) fail("disparity_step_px", "must be ≥ 0");
  if (disparity_step_px > 0.0 && !(baseline > 0.0))
    fail("baseline", "must be positive when disparity quantisation is on");
  if (lateral_sigma_px < 0.0) fail("lateral_sigma_px", "must be ≥ 0");
  if (dropout_probability < 0.0 || dropout_probability > 1.0)
    fail("dropout_probability", "must be in [0, 1]");
  if (!(max_incidence_deg > 0.0) || max_incidence_deg > 90.0)
    fail("max_incidence_deg", "must be in (0, 90]");
}

double RgbdParams::axialSigma(double z, double theta) const {
  // Nguyen et al. 2012, eq. 6 (the angle term, eq. 7, applies when θ < π/2).
  double s = axial_sigma_a + axial_sigma_b * (z - axial_sigma_z0) * (z - axial_sigma_z0);
  if (theta > 0.0 && theta < M_PI_2 - 1e-3 && z > 0.0) {
    const double g = M_PI_2 - theta;
    s += axial_sigma_angle / std::sqrt(z) * theta * theta / (g * g);
  }
  return s;
}

double RgbdParams::quantize(double z) const {
  if (!(disparity_step_px > 0.0) || !(z > 0.0)) return z;
  const double fb = fx * baseline;
  const double d = std::round(fb / z / disparity_step_px) * disparity_step_px;
  return d > 0.0 ? fb / d : 0.0;
}

std::size_t DepthFrame::validCount() const {
  return static_cast<std::size_t>(
      std::count_if(depth.begin(), depth.end(), [](float d) { return d > 0.f; }));
}

RgbdSimulator::RgbdSimulator(RgbdParams params) : params_(std::move(params)) {
  params_.validate();
  // θ² / (π/2 − θ)² of Nguyen et al.'s eq. 7 sampled over cos θ ∈ [0, 1]; infinite at grazing
  // incidence, which max_incidence_deg removes before it is used.
  angle_term_.resize(kAngleCells + 1);
  for (int k = 0; k <= kAngleCells; ++k) {
    const double theta = std::acos(static_cast<double>(k) / kAngleCells);
    const double g = std::max(M_PI_2 - theta, 1e-3);
    angle_term_[static_cast<std::size_t>(k)] = static_cast<float>(theta * theta / (g * g));
  }
}

DepthFrame RgbdSimulator::render(const RaycastScene& scene, const Eigen::Isometry3d& T_world_cam,
                                 double t, std::uint64_t seed) const {
  const auto& S = scene.impl();
  const RgbdParams& P = params_;
  DepthFrame f;
  f.width = P.width;
  f.height = P.height;
  f.timestamp = t;
  f.depth.assign(P.pixels(), 0.f);
  if (P.color) f.rgb.assign(3 * P.pixels(), 0);

  const Eigen::Matrix3f R = T_world_cam.linear().cast<float>();
  const Eigen::Vector3f o = T_world_cam.translation().cast<float>();
  const Eigen::Vector3f proj = (T_world_cam * Eigen::Vector3d(P.baseline, 0, 0)).cast<float>();
  const float cos_max = static_cast<float>(std::cos(P.max_incidence_deg * kDegToRad));
  const bool noisy = P.noise;
  const float near_t = 0.05f;  // nearer surfaces still occlude; min_depth is applied afterwards
  const float far_t = static_cast<float>(P.max_depth * 1.25);
  constexpr int kTile = 4;  // 4×4 pixel tiles = one 16-ray packet (coherent rays)
  const int tiles_x = (P.width + kTile - 1) / kTile;
  const int tile_rows = (P.height + kTile - 1) / kTile;

  parallelFor(static_cast<std::size_t>(tile_rows), P.threads, [&](std::size_t tr) {
    Rng rng(hashSeed(seed, 0x4b1d, tr));
    Rng crng(hashSeed(seed, 0xc010, tr));  // colour noise: the depth's draws stay as they were
    RayPacket16 pk;
    alignas(64) RTCRay16 shadow;
    alignas(64) int shadow_valid[16];
    int px_u[16], px_v[16];
    float depth[16], cosv[16];
    for (int tx = 0; tx < tiles_x; ++tx) {
      pk.clear();
      int lanes = 0;
      for (int dv = 0; dv < kTile; ++dv)
        for (int du = 0; du < kTile; ++du) {
          const int u = tx * kTile + du, v = static_cast<int>(tr) * kTile + dv;
          const int i = dv * kTile + du;
          px_u[i] = u;
          px_v[i] = v;
          if (u >= P.width || v >= P.height) continue;
          double uu = u, vv = v;
          if (noisy && P.lateral_sigma_px > 0.0) {
            uu += P.lateral_sigma_px * rng.normalFast();
            vv += P.lateral_sigma_px * rng.normalFast();
          }
          // Direction with unit z in the camera frame, so the hit's t is the depth.
          const Eigen::Vector3f dc(static_cast<float>((uu - P.cx) / P.fx),
                                   static_cast<float>((vv - P.cy) / P.fy), 1.f);
          const Eigen::Vector3f dw = R * dc;
          pk.set(i, o.x(), o.y(), o.z(), dw.x(), dw.y(), dw.z(), near_t, far_t);
          ++lanes;
        }
      if (lanes == 0) continue;
      intersectPacket(S, pk, true);
      bool any_shadow = false;
      for (int i = 0; i < 16; ++i) {
        depth[i] = 0.f;
        shadow_valid[i] = 0;
        if (!pk.hit(i)) continue;
        const float z = pk.rh.ray.tfar[i];
        const float ci = pk.cosIncidence(i);
        cosv[i] = ci;
        if (ci < cos_max) continue;
        depth[i] = z;
        if (P.projector_shadow && P.baseline > 0.0) {
          // Segment from the surface point to the projector; blocked = no structured light.
          const float X = pk.rh.ray.org_x[i] + z * pk.rh.ray.dir_x[i];
          const float Y = pk.rh.ray.org_y[i] + z * pk.rh.ray.dir_y[i];
          const float Z = pk.rh.ray.org_z[i] + z * pk.rh.ray.dir_z[i];
          const float dx = proj.x() - X, dy = proj.y() - Y, dz = proj.z() - Z;
          const float len = std::sqrt(dx * dx + dy * dy + dz * dz);
          shadow.org_x[i] = X;
          shadow.org_y[i] = Y;
          shadow.org_z[i] = Z;
          shadow.dir_x[i] = dx;
          shadow.dir_y[i] = dy;
          shadow.dir_z[i] = dz;
          shadow.tnear[i] = len > 0.f ? 0.01f / len : 0.f;
          shadow.tfar[i] = 1.f;
          shadow.time[i] = 0.f;
          shadow.mask[i] = 0xFFFFFFFFu;
          shadow.id[i] = static_cast<unsigned>(i);
          shadow.flags[i] = 0;
          shadow_valid[i] = -1;
          any_shadow = true;
        }
      }
      if (any_shadow) occludedPacket(S, shadow, shadow_valid, true);
      for (int i = 0; i < 16; ++i) {
        const int u = px_u[i], v = px_v[i];
        if (u >= P.width || v >= P.height || !pk.hit(i)) continue;
        const std::size_t idx = static_cast<std::size_t>(v) * P.width + u;
        if (P.color) {
          const auto& mp = materialProperties(S.mesh.materials[pk.rh.hit.primID[i]]);
          const float z = pk.rh.ray.tfar[i];
          const Eigen::Vector3f X(pk.rh.ray.org_x[i] + z * pk.rh.ray.dir_x[i],
                                  pk.rh.ray.org_y[i] + z * pk.rh.ray.dir_y[i],
                                  pk.rh.ray.org_z[i] + z * pk.rh.ray.dir_z[i]);
          const Eigen::Vector3f n(pk.rh.hit.Ng_x[i], pk.rh.hit.Ng_y[i], pk.rh.hit.Ng_z[i]);
          const float shade = lambertShade(n) * surfaceTexture(X);
          for (int k = 0; k < 3; ++k) {
            float c = mp.rgb[k] * shade;
            if (noisy) c += kColorNoise * crng.normalFast();
            f.rgb[3 * idx + k] =
                static_cast<std::uint8_t>(std::clamp(std::lround(c), long{0}, long{255}));
          }
        }
        float z = depth[i];
        if (!(z > 0.f)) continue;
        if (shadow_valid[i] && shadow.tfar[i] < 0.f) continue;  // projector shadow
        if (noisy) {
          if (P.dropout_probability > 0.0 && rng.uniformf() < P.dropout_probability) continue;
          // σ(z, θ) with the incidence term from a table over cos θ (no acos per pixel).
          const float ci = std::min(1.f, std::max(0.f, cosv[i]));
          const float ft = ci * static_cast<float>(kAngleCells);
          const int it = std::min(kAngleCells - 1, static_cast<int>(ft));
          const float g = angle_term_[it] + (ft - it) * (angle_term_[it + 1] - angle_term_[it]);
          const float dz = z - static_cast<float>(P.axial_sigma_z0);
          const float sigma = static_cast<float>(P.axial_sigma_a) +
                              static_cast<float>(P.axial_sigma_b) * dz * dz +
                              static_cast<float>(P.axial_sigma_angle) * g / std::sqrt(z);
          z += sigma * rng.normalFast();
        }
        z = static_cast<float>(P.quantize(z));
        if (z < P.min_depth || z > P.max_depth) continue;
        f.depth[idx] = z;
      }
    }
  });
  return f;
}

PointCloud RgbdSimulator::backProject(const DepthFrame& frame) const {
  PointCloud c;
  c.frame_id = "camera";
  c.timestamp = frame.timestamp;
  c.reserve(frame.validCount());
  for (int v = 0; v < frame.height; ++v)
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.at(u, v);
      if (!(z > 0.f)) continue;
      c.points.emplace_back(static_cast<float>((u - params_.cx) / params_.fx) * z,
                            static_cast<float>((v - params_.cy) / params_.fy) * z, z);
    }
  return c;
}

}  // namespace obm::sim
