#pragma once
/// \file rgbd_camera.hpp
/// A structured-light RGB-D camera (Kinect v1 / PrimeSense class) simulated by ray casting one ray
/// per pixel. Camera frame: the optical frame, x right, y down, z forward; depth is z (not the ray
/// length), as in TUM / ICL-NUIM depth images.
///
/// Noise model (all optional):
///  - axial: σ_z(z, θ) = a + b·(z − z₀)² + c·θ²/(√z·(π/2 − θ)²) with a = 1.2 mm, b = 1.9 mm/m²,
///    z₀ = 0.4 m, c = 0.1 mm·√m (Nguyen, Izadi & Lovell, "Modeling Kinect Sensor Noise for
///    Improved 3D Reconstruction and Tracking", 3DIMPVT 2012, eqs. 6–7), θ the incidence angle;
///  - lateral: each ray leaves from a pixel position jittered by N(0, σ_L²) px (σ_L ≈ 0.8 px in
///    the same paper), which frays depth edges;
///  - quantisation: disparity d = f·b/z is rounded to 1/8 px (Kinect's sub-pixel step; Khoshelham
///    & Elberink 2012), so the depth step grows with z²;
///  - holes: incidence beyond `max_incidence_deg`, random loss, and the projector's shadow (a
///    surface point the projector, `projector_offset` to the right of the camera, cannot see).
///
/// Colour (`color`): material albedo × a procedural texture fixed to the surface (two octaves of
/// value noise, 7 and 25 cm) × Lambertian shading under a fixed light plus ambient — independent
/// of the viewpoint, as the brightness constancy of photometric tracking assumes — plus
/// N(0, 2²) grey-level noise when `noise` (drawn apart from the depth noise).
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "obm/config/config_node.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/sim/scene.hpp"

namespace obm::sim {

/// Parameters of the RGB-D camera. Defaults: Kinect v1 / TUM RGB-D (640×480, f = 525 px).
struct RgbdParams {
  int width = 640;         ///< [px]
  int height = 480;        ///< [px]
  double fx = 525.0;       ///< [px]
  double fy = 525.0;       ///< [px]
  double cx = 319.5;       ///< [px]
  double cy = 239.5;       ///< [px]
  double min_depth = 0.4;  ///< [m] nearer surfaces give no depth
  double max_depth = 8.0;  ///< [m] farther surfaces give no depth
  double rate_hz = 30.0;   ///< [Hz] frame rate

  bool noise = true;                   ///< master switch for everything random below
  double axial_sigma_a = 0.0012;       ///< [m] Nguyen et al. constant term
  double axial_sigma_b = 0.0019;       ///< [1/m] Nguyen et al. quadratic term (× (z − z₀)²)
  double axial_sigma_z0 = 0.4;         ///< [m]
  double axial_sigma_angle = 0.0001;   ///< [m^1.5] Nguyen et al. incidence-angle term
  double lateral_sigma_px = 0.8;       ///< [px] pixel jitter (0 disables)
  double disparity_step_px = 0.125;    ///< [px] disparity quantisation (0 disables)
  double baseline = 0.075;             ///< [m] projector–camera baseline (Kinect: 7.5 cm)
  bool projector_shadow = true;        ///< holes where the projector cannot see the surface
  double max_incidence_deg = 80.0;     ///< [deg] steeper surfaces return nothing
  double dropout_probability = 0.002;  ///< random pixel loss
  bool color = true;                   ///< also render a textured, shaded colour image
  int threads = 0;                     ///< ray-casting threads (0 = all cores)

  /// Reads the keys above from a `sensor:` map. Throws ConfigError naming the key.
  static RgbdParams load(const ConfigNode& node);
  /// Throws ConfigError naming the offending key (e.g. a zero-pixel image).
  void validate(const std::string& where = "rgbd") const;
  std::size_t pixels() const { return static_cast<std::size_t>(width) * height; }
  /// Standard deviation [m] of the axial noise at depth z and incidence θ [rad].
  double axialSigma(double z, double theta = 0.0) const;
  /// Depth after disparity quantisation (identity when disparity_step_px = 0).
  double quantize(double z) const;
};

/// One depth frame (and optional colour).
struct DepthFrame {
  int width = 0, height = 0;
  std::vector<float> depth;       ///< [m] row-major, 0 = no measurement
  std::vector<std::uint8_t> rgb;  ///< row-major RGB (empty when colour is off)
  double timestamp = 0.0;         ///< [s]
  float at(int u, int v) const { return depth[static_cast<std::size_t>(v) * width + u]; }
  std::size_t validCount() const;
};

class RgbdSimulator {
 public:
  /// Validates the parameters (throws ConfigError).
  explicit RgbdSimulator(RgbdParams params);
  const RgbdParams& params() const { return params_; }

  /// Renders the frame seen from T_world_cam (optical frame). `seed` makes the noise
  /// reproducible for any thread count.
  DepthFrame render(const RaycastScene& scene, const Eigen::Isometry3d& T_world_cam, double t,
                    std::uint64_t seed) const;

  /// Back-projects the valid pixels into the camera frame (frame_id "camera").
  PointCloud backProject(const DepthFrame& frame) const;

 private:
  static constexpr int kAngleCells = 1024;
  RgbdParams params_;
  std::vector<float> angle_term_;  // incidence term of the axial noise over cos θ
};

}  // namespace obm::sim
