#include "obm/sim/scene.hpp"

#include <cstring>
#include <string>

#include "embree_scene.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"

namespace obm::sim {

namespace {
void embreeErrorCallback(void*, RTCError code, const char* str) {
  OBM_LOG_ERROR("sim", "Embree error " << static_cast<int>(code) << ": " << (str ? str : ""));
}

std::string embreeErrorText(RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE:
      return "none";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}
}  // namespace

RaycastScene::Impl::~Impl() {
  if (scene) rtcReleaseScene(scene);
  if (device) rtcReleaseDevice(device);
}

RaycastScene::RaycastScene(SceneMesh mesh, const RaycastSceneOptions& options)
    : impl_(std::make_unique<Impl>()) {
  mesh.validate();
  if (mesh.mesh.faces.empty())
    throw ContractError("scene mesh '" + mesh.mesh.name + "' has no triangles to ray cast");
  Impl& s = *impl_;
  s.mesh = std::move(mesh);
  s.bounds = s.mesh.bounds();

  const std::string cfg =
      options.build_threads > 0 ? "threads=" + std::to_string(options.build_threads) : "";
  s.device = rtcNewDevice(cfg.empty() ? nullptr : cfg.c_str());
  if (!s.device)
    throw Error("cannot create an Embree device: " + embreeErrorText(rtcGetDeviceError(nullptr)));
  rtcSetDeviceErrorFunction(s.device, embreeErrorCallback, nullptr);

  s.scene = rtcNewScene(s.device);
  rtcSetSceneFlags(s.scene, options.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  rtcSetSceneBuildQuality(s.scene,
                          options.high_quality ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM);

  RTCGeometry geom = rtcNewGeometry(s.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  const auto& V = s.mesh.mesh.vertices;
  const auto& F = s.mesh.mesh.faces;
  // Embree copies into its own (padded) buffers; the mesh stays with us for materials/pictures.
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), V.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), F.size()));
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    throw Error("Embree could not allocate buffers for " + std::to_string(F.size()) +
                " triangles: " + embreeErrorText(rtcGetDeviceError(s.device)));
  }
  for (std::size_t i = 0; i < V.size(); ++i)
    std::memcpy(vb + 3 * i, V[i].data(), 3 * sizeof(float));
  for (std::size_t i = 0; i < F.size(); ++i)
    for (int k = 0; k < 3; ++k) ib[3 * i + k] = static_cast<unsigned>(F[i][k]);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(s.scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(s.scene);
  const RTCError err = rtcGetDeviceError(s.device);
  if (err != RTC_ERROR_NONE)
    throw Error("Embree could not build the scene of " + std::to_string(F.size()) +
                " triangles: " + embreeErrorText(err));
  OBM_LOG_DEBUG("sim", "Embree scene: " << F.size() << " triangles, " << V.size() << " vertices");
}

RaycastScene::~RaycastScene() = default;
RaycastScene::RaycastScene(RaycastScene&&) noexcept = default;
RaycastScene& RaycastScene::operator=(RaycastScene&&) noexcept = default;

const SceneMesh& RaycastScene::mesh() const {
  return impl_->mesh;
}
const Eigen::AlignedBox3d& RaycastScene::bounds() const {
  return impl_->bounds;
}

namespace {
RayHit toHit(const RaycastScene::Impl& s, const RayPacket16& p, int i) {
  RayHit h;
  if (!p.hit(i)) return h;
  h.range = p.rh.ray.tfar[i];
  h.face = p.rh.hit.primID[i];
  h.material = s.mesh.materials[h.face];
  Eigen::Vector3f n(p.rh.hit.Ng_x[i], p.rh.hit.Ng_y[i], p.rh.hit.Ng_z[i]);
  const Eigen::Vector3f d(p.rh.ray.dir_x[i], p.rh.ray.dir_y[i], p.rh.ray.dir_z[i]);
  if (n.squaredNorm() > 0.f) n.normalize();
  if (n.dot(d) > 0.f) n = -n;
  h.normal = n;
  h.cos_incidence = p.cosIncidence(i);
  return h;
}
}  // namespace

RayHit RaycastScene::intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                               float t_min, float t_max) const {
  RayPacket16 p;
  p.clear();
  p.set(0, origin.x(), origin.y(), origin.z(), direction.x(), direction.y(), direction.z(), t_min,
        t_max);
  intersectPacket(*impl_, p, false);
  return toHit(*impl_, p, 0);
}

void RaycastScene::intersect(const std::vector<Eigen::Vector3f>& origins,
                             const std::vector<Eigen::Vector3f>& directions, float t_min,
                             float t_max, std::vector<RayHit>& hits) const {
  OBM_ASSERT(origins.size() == directions.size(), "one origin per direction");
  hits.assign(origins.size(), RayHit{});
  RayPacket16 p;
  for (std::size_t b = 0; b < origins.size(); b += 16) {
    p.clear();
    const int n = static_cast<int>(std::min<std::size_t>(16, origins.size() - b));
    for (int i = 0; i < n; ++i) {
      const auto& o = origins[b + i];
      const auto& d = directions[b + i];
      p.set(i, o.x(), o.y(), o.z(), d.x(), d.y(), d.z(), t_min, t_max);
    }
    intersectPacket(*impl_, p, false);
    for (int i = 0; i < n; ++i) hits[b + i] = toHit(*impl_, p, i);
  }
}

bool RaycastScene::occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                            float t_min, float t_max) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  r.org_x = origin.x();
  r.org_y = origin.y();
  r.org_z = origin.z();
  r.dir_x = direction.x();
  r.dir_y = direction.y();
  r.dir_z = direction.z();
  r.tnear = t_min;
  r.tfar = t_max;
  r.time = 0.f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(impl_->scene, &ctx, &r);
  return r.tfar < 0.f && std::isinf(r.tfar);
}

}  // namespace obm::sim
