#pragma once
// Private: the Embree side of RaycastScene, shared by the sensor models. Not installed.
#include <embree3/rtcore.h>

#include <cmath>

#include "obm/sim/scene.hpp"

namespace obm::sim {

struct RaycastScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  SceneMesh mesh;
  Eigen::AlignedBox3d bounds;
  ~Impl();
};

/// A 16-wide ray packet with its validity mask, aligned as Embree requires.
struct alignas(64) RayPacket16 {
  RTCRayHit16 rh;
  alignas(64) int valid[16];

  /// Marks all lanes invalid and resets hit ids.
  void clear() {
    for (int i = 0; i < 16; ++i) valid[i] = 0;
  }
  /// Sets lane `i` (origin, direction, t range) and marks it valid.
  void set(int i, float ox, float oy, float oz, float dx, float dy, float dz, float tnear,
           float tfar) {
    rh.ray.org_x[i] = ox;
    rh.ray.org_y[i] = oy;
    rh.ray.org_z[i] = oz;
    rh.ray.dir_x[i] = dx;
    rh.ray.dir_y[i] = dy;
    rh.ray.dir_z[i] = dz;
    rh.ray.tnear[i] = tnear;
    rh.ray.tfar[i] = tfar;
    rh.ray.time[i] = 0.f;
    rh.ray.mask[i] = 0xFFFFFFFFu;
    rh.ray.id[i] = static_cast<unsigned>(i);
    rh.ray.flags[i] = 0;
    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    valid[i] = -1;
  }
  bool hit(int i) const { return valid[i] && rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID; }
  /// |cos| of the incidence angle of lane i (geometric normal vs. ray direction).
  float cosIncidence(int i) const {
    const float nx = rh.hit.Ng_x[i], ny = rh.hit.Ng_y[i], nz = rh.hit.Ng_z[i];
    const float dx = rh.ray.dir_x[i], dy = rh.ray.dir_y[i], dz = rh.ray.dir_z[i];
    const float nn = nx * nx + ny * ny + nz * nz, dd = dx * dx + dy * dy + dz * dz;
    if (nn <= 0.f || dd <= 0.f) return 0.f;
    return std::fabs(nx * dx + ny * dy + nz * dz) / std::sqrt(nn * dd);
  }
};

/// Intersects a packet; `coherent` hints Embree that the rays are spatially coherent (camera).
inline void intersectPacket(const RaycastScene::Impl& s, RayPacket16& p, bool coherent) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  rtcIntersect16(p.valid, s.scene, &ctx, &p.rh);
}

/// Occlusion test of a packet: on return, tfar of occluded lanes is −∞ (Embree's convention).
inline void occludedPacket(const RaycastScene::Impl& s, RTCRay16& r, const int* valid,
                           bool coherent) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  rtcOccluded16(valid, s.scene, &ctx, &r);
}

}  // namespace obm::sim
