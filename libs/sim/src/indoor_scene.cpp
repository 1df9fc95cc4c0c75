// Procedural indoor scenes: an office floor of rooms along a corridor, and a furnished room
// around a given hand-held trajectory.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "indoor_layout.hpp"
#include "layout.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/sim/random.hpp"
#include "props.hpp"

namespace obm::sim {

namespace fs = std::filesystem;
using detail::V2;
using V3 = Eigen::Vector3d;
using Iso = Eigen::Isometry3d;

IndoorSceneParams IndoorSceneParams::load(const ConfigNode& n) {
  IndoorSceneParams p;
  n.checkKeys({"type", "rooms_per_side", "room_width_min", "room_width_max", "room_depth",
               "corridor_width", "wall_height", "wall_thickness", "door_width", "door_height",
               "clutter_per_room", "mesh_dir", "meshes", "max_meshes", "max_mesh_faces",
               "room_margin", "min_room_size"});
  n.get("rooms_per_side", p.rooms_per_side);
  n.get("room_width_min", p.room_width_min);
  n.get("room_width_max", p.room_width_max);
  n.get("room_depth", p.room_depth);
  n.get("corridor_width", p.corridor_width);
  n.get("wall_height", p.wall_height);
  n.get("wall_thickness", p.wall_thickness);
  n.get("door_width", p.door_width);
  n.get("door_height", p.door_height);
  n.get("clutter_per_room", p.clutter_per_room);
  n.get("mesh_dir", p.mesh_dir);
  n.get("meshes", p.meshes);
  n.get("max_meshes", p.max_meshes);
  n.get("max_mesh_faces", p.max_mesh_faces);
  n.get("room_margin", p.room_margin);
  n.get("min_room_size", p.min_room_size);
  auto fail = [&](const char* key, const std::string& what) {
    throw ConfigError(n.where(key) + ": " + what);
  };
  if (p.rooms_per_side < 1) fail("rooms_per_side", "must be ≥ 1");
  if (p.room_width_min < 4.0 || p.room_width_max < p.room_width_min)
    fail("room_width_max", "need 4 ≤ room_width_min ≤ room_width_max");
  if (p.room_depth < 4.0) fail("room_depth", "must be ≥ 4 m");
  if (p.corridor_width < 1.6) fail("corridor_width", "must be ≥ 1.6 m");
  if (p.wall_height < 2.3) fail("wall_height", "must be ≥ 2.3 m");
  if (p.door_width < 0.8 || p.door_width > 2.0) fail("door_width", "must be in [0.8, 2] m");
  if (p.door_height < 1.9 || p.door_height >= p.wall_height)
    fail("door_height", "must be in [1.9 m, wall_height)");
  if (p.clutter_per_room < 0) fail("clutter_per_room", "must be ≥ 0");
  return p;
}

namespace detail {

IndoorLayout indoorLayout(const IndoorSceneParams& p) {
  Rng rng(hashSeed(p.seed, 0x1a70));
  IndoorLayout L;
  const int n = p.rooms_per_side;
  std::vector<double> ws(static_cast<std::size_t>(n)), wn(static_cast<std::size_t>(n));
  double ts = 0, tn = 0;
  for (int k = 0; k < n; ++k) ts += ws[k] = rng.uniform(p.room_width_min, p.room_width_max);
  for (int k = 0; k < n; ++k) tn += wn[k] = rng.uniform(p.room_width_min, p.room_width_max);
  L.length = ts;
  const double hw = 0.5 * p.corridor_width;
  for (int side = -1; side <= 1; side += 2) {
    double x = 0;
    const auto& w = side < 0 ? ws : wn;
    const double scale = side < 0 ? 1.0 : ts / tn;  // both sides span the same length
    for (int k = 0; k < n; ++k) {
      IndoorRoom r;
      r.x0 = x;
      r.x1 = x + w[static_cast<std::size_t>(k)] * scale;
      r.y_wall = side * hw;
      r.y_outer = side * (hw + p.room_depth);
      r.side = side;
      const double slack = 0.5 * r.width() - 0.8 - 0.5 * p.door_width;
      r.door_x = 0.5 * (r.x0 + r.x1) + rng.uniform(-0.5, 0.5) * std::max(0.0, slack);
      L.rooms.push_back(r);
      x = r.x1;
    }
  }
  L.start_room = 0;                                    // first south room
  L.goal_room = static_cast<int>(L.rooms.size()) - 1;  // last north room (far end)
  return L;
}

}  // namespace detail

namespace {

// Oriented box from ground-plane points a→c (helper for walls and panels).
void slab(MeshBuilder& b, const V2& a, const V2& c, double width, double z0, double z1,
          Material m) {
  detail::addOrientedBox(b, V3(a.x(), a.y(), 0), V3(c.x(), c.y(), 0), width, z0, z1, m);
}

struct WallOpening {
  double a0, a1, z0, z1;
  bool glass;
};

// A straight wall from p0 along unit u for length L, thickness t centred on the line, height H,
// with rectangular openings (along-coordinates a, heights z).
void wall(MeshBuilder& b, const V2& p0, const V2& u, double L, double t, double H,
          std::vector<WallOpening> ops) {
  std::sort(ops.begin(), ops.end(),
            [](const WallOpening& x, const WallOpening& y) { return x.a0 < y.a0; });
  double a = -0.5 * t;  // overlap the corners
  for (const auto& o : ops) {
    if (o.a0 > a) slab(b, p0 + a * u, p0 + o.a0 * u, t, 0, H, Material::Wall);
    if (o.z0 > 0) slab(b, p0 + o.a0 * u, p0 + o.a1 * u, t, 0, o.z0, Material::Wall);
    if (o.z1 < H) slab(b, p0 + o.a0 * u, p0 + o.a1 * u, t, o.z1, H, Material::Wall);
    if (o.glass) slab(b, p0 + o.a0 * u, p0 + o.a1 * u, 0.02, o.z0, o.z1, Material::Glass);
    a = o.a1;
  }
  if (L + 0.5 * t > a) slab(b, p0 + a * u, p0 + (L + 0.5 * t) * u, t, 0, H, Material::Wall);
}

Iso pose2(const V2& p, double z, double yaw) {
  Iso T = Iso::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, V3::UnitZ()).toRotationMatrix();
  T.translation() = V3(p.x(), p.y(), z);
  return T;
}

/// CAD clutter from a mesh folder (the CGAL sample meshes), normalised to stand on z = 0.
class MeshClutter {
 public:
  MeshClutter(const IndoorSceneParams& p, Rng& rng) {
    std::string dir = p.mesh_dir;
    if (dir == "auto") dir = autoDir();
    if (dir.empty()) return;
    if (!fs::is_directory(dir))
      throw IoError("scene.mesh_dir: mesh folder '" + dir + "' does not exist");
    std::vector<std::string> files;
    if (!p.meshes.empty()) {
      for (const auto& m : p.meshes) files.push_back((fs::path(dir) / m).string());
    } else {
      for (const auto& e : fs::directory_iterator(dir)) {
        const std::string ext = e.path().extension().string();
        if (ext == ".off" || ext == ".ply" || ext == ".obj") files.push_back(e.path().string());
      }
      std::sort(files.begin(), files.end());
      // A seeded choice of max_meshes files, small ones preferred (by file size).
      std::vector<std::pair<std::uintmax_t, std::string>> sized;
      for (const auto& f : files) sized.emplace_back(fs::file_size(f), f);
      std::sort(sized.begin(), sized.end());
      files.clear();
      for (const auto& s : sized)
        if (s.first < 3'000'000) files.push_back(s.second);
      for (std::size_t i = files.size(); i > 1; --i) std::swap(files[i - 1], files[rng.index(i)]);
      if (files.size() > static_cast<std::size_t>(p.max_meshes))
        files.resize(static_cast<std::size_t>(p.max_meshes));
    }
    for (const auto& f : files) {
      TriangleMesh m = io::readMesh(f);  // throws naming the file
      if (m.faces.empty() || static_cast<int>(m.faces.size()) > p.max_mesh_faces) continue;
      Eigen::AlignedBox3f bb;
      for (const auto& v : m.vertices) bb.extend(v);
      const float ext = bb.sizes().maxCoeff();
      if (!(ext > 0.f)) continue;
      const Eigen::Vector3f c = bb.center();
      for (auto& v : m.vertices)
        v = (v - c) / ext + Eigen::Vector3f(0, 0, 0.5f * bb.sizes().z() / ext);
      meshes_.push_back(std::move(m));
    }
    OBM_LOG_INFO("sim", "indoor clutter: " << meshes_.size() << " meshes from '" << dir << "'");
  }

  bool empty() const { return meshes_.empty(); }

  /// Appends a random mesh standing at the origin of T with its largest side `size`.
  void add(MeshBuilder& b, const Iso& T, double size, Rng& rng) const {
    TriangleMesh m = meshes_[rng.index(meshes_.size())];
    for (auto& v : m.vertices) v *= static_cast<float>(size);
    m.transform(T);
    b.mesh().append(m, Material::Clutter);
  }

  static std::string autoDir() {
    if (const char* e = std::getenv("OBM_CGAL_DATA"))
      if (fs::is_directory(e)) return e;
    std::string cache;
    if (const char* c = std::getenv("OBM_CACHE"))
      cache = c;
    else if (const char* h = std::getenv("HOME"))
      cache = std::string(h) + "/.cache/obmslam";
    const std::string d = cache + "/cgal/data/meshes";
    if (!cache.empty() && fs::is_directory(d)) return d;
    OBM_LOG_WARN("sim",
                 "scene.mesh_dir is 'auto' but no CGAL meshes were found (set OBM_CGAL_DATA "
                 "or run scripts/get_cgal_meshes.sh); using procedural clutter only");
    return {};
  }

 private:
  std::vector<TriangleMesh> meshes_;
};

// A clutter object on a surface at height z (mesh when available, else procedural).
void clutterAt(MeshBuilder& b, const MeshClutter& mc, const V2& p, double z, Rng& rng) {
  const Iso T = pose2(p, z, rng.uniform(0, 2 * M_PI));
  if (!mc.empty() && rng.bernoulli(0.6))
    mc.add(b, T, rng.uniform(0.12, 0.32), rng);
  else
    detail::addSmallObject(b, T, rng);
}

// Furniture of one office room; keeps the walk's free area and the door approach clear.
void furnishRoom(MeshBuilder& b, const detail::IndoorRoom& r, const IndoorSceneParams& P,
                 const MeshClutter& mc, Rng& rng, std::size_t& n_objects) {
  const double W = r.width() - P.wall_thickness, D = r.depth() - P.wall_thickness;
  const double u0 = 0.5 * P.wall_thickness;             // inner face offsets
  const double yaw_in = r.side > 0 ? M_PI_2 : -M_PI_2;  // facing into the room (+v)
  auto at = [&](double u, double v) { return r.toWorld(u0 + u, u0 + v); };
  // Desk against the back wall, chairs in front of it, a monitor and clutter on top.
  const double tl = rng.uniform(1.4, 1.8), tw = rng.uniform(0.7, 0.85);
  const V2 tc = at(0.5 * W, D - 0.5 * tw - 0.05);
  const double th = detail::addTable(b, pose2(tc, 0, 0), tl, tw, 0.74);
  // Monitor near the wall, its screen (facing −x of its frame) towards the room.
  detail::addMonitor(b, pose2(tc + V2(0, 0.15 * r.side), th, yaw_in));
  const int chairs = 1 + static_cast<int>(rng.index(2));
  for (int k = 0; k < chairs; ++k)  // facing the desk (+x of the chair frame = into the room)
    detail::addChair(b, pose2(at(0.5 * W + (k - 0.5 * (chairs - 1)) * 0.7, D - tw - 0.45), 0,
                              yaw_in + rng.uniform(-0.3, 0.3)));
  // Shelf on one side wall, cabinet on the other; their frames have the back at +y, so +y must
  // point at the wall: yaw +90° on the west wall (u = 0), −90° on the east wall (u = W).
  const bool shelf_left = rng.bernoulli(0.5);
  const double sl = std::min(D - 2.6, rng.uniform(1.0, 1.8));
  if (sl > 0.6) {
    const double vc = 1.25 + 0.5 * sl;
    detail::addShelf(b,
                     pose2(at(shelf_left ? 0.36 : W - 0.36, vc), 0, shelf_left ? M_PI_2 : -M_PI_2),
                     sl, 0.36, rng.uniform(1.7, 2.0), 4 + static_cast<int>(rng.index(2)), rng);
  }
  const double cl = rng.uniform(0.8, 1.2);
  const Iso Tc =
      pose2(at(shelf_left ? W - 0.44 : 0.44, 1.2 + 0.5 * cl), 0, shelf_left ? -M_PI_2 : M_PI_2);
  detail::addCabinet(b, Tc, cl, 0.44, 0.85);
  const V3 cc3 = Tc * V3(0, 0.22, 0);
  const V2 cc(cc3.x(), cc3.y());
  // Clutter on the desk, the cabinet, and on the floor in the back corners.
  const int n = static_cast<int>(std::round(P.clutter_per_room * rng.uniform(0.6, 1.4)));
  for (int k = 0; k < n; ++k) {
    const double pick = rng.uniform();
    if (pick < 0.55) {
      clutterAt(b, mc, tc + V2(rng.uniform(-0.45, 0.45) * tl, rng.uniform(-0.3, 0.3) * tw), th,
                rng);
    } else if (pick < 0.8) {
      const V3 q = Tc * V3(rng.uniform(-0.4, 0.4) * cl, 0.22 + rng.uniform(-0.1, 0.1), 0.0);
      clutterAt(b, mc, V2(q.x(), q.y()), 0.85, rng);
    } else {
      const double u = rng.bernoulli(0.5) ? rng.uniform(0.2, 0.5) : W - rng.uniform(0.2, 0.5);
      clutterAt(b, mc, at(u, D - rng.uniform(0.2, 0.5)), 0.0, rng);
    }
    ++n_objects;
  }
}

}  // namespace

GeneratedScene generateIndoorFloor(const IndoorSceneParams& P) {
  const detail::IndoorLayout L = detail::indoorLayout(P);
  SceneMesh mesh;
  MeshBuilder b(mesh);
  Rng rng(hashSeed(P.seed, 0x1d00));
  const MeshClutter mc(P, rng);
  const double H = P.wall_height, t = P.wall_thickness, hw = 0.5 * P.corridor_width;
  const double y_s = -(hw + P.room_depth), y_n = hw + P.room_depth;
  // Floor and ceiling slabs.
  b.aabb(V3(-t, y_s - t, -0.1), V3(L.length + t, y_n + t, 0.0), Material::Floor);
  // The ceiling starts 1 mm above the walls so that a top view can look past it onto them.
  b.aabb(V3(-t, y_s - t, H + 0.001), V3(L.length + t, y_n + t, H + 0.1), Material::Ceiling);
  // End walls (a window at each end of the corridor).
  for (double x : {0.0, L.length})
    wall(b, V2(x, y_s), V2(0, 1), y_n - y_s, t, H, {{-y_s - 0.6, -y_s + 0.6, 0.9, 2.2, true}});
  // Outer walls with windows per room, corridor walls with doors, partitions.
  std::size_t n_objects = 0;
  for (std::size_t k = 0; k < L.rooms.size(); ++k) {
    const auto& r = L.rooms[k];
    const double xm = 0.5 * (r.x0 + r.x1);
    wall(b, V2(r.x0, r.y_outer), V2(1, 0), r.width(), t, H,
         {{xm - r.x0 - 0.8, xm - r.x0 + 0.8, 0.9, 2.2, true}});
    wall(b, V2(r.x0, r.y_wall), V2(1, 0), r.width(), t, H,
         {{r.door_x - r.x0 - 0.5 * P.door_width, r.door_x - r.x0 + 0.5 * P.door_width, 0.0,
           P.door_height, false}});
    if (r.x0 > 0) wall(b, V2(r.x0, r.y_wall), V2(0, r.side), P.room_depth, t, H, {});
    // Door leaf: open at 90° on the walked rooms, at a random angle elsewhere.
    const bool walked = static_cast<int>(k) == L.start_room || static_cast<int>(k) == L.goal_room;
    const double ang = walked ? M_PI_2 : rng.uniform(0.0, 1.0) < 0.3 ? 0.0 : rng.uniform(0.6, 1.6);
    // Hinged on the side away from the room's centre, so an open leaf stays out of the way.
    const double hs = r.door_x >= xm ? 1.0 : -1.0;
    const V2 hinge(r.door_x + hs * 0.5 * P.door_width, r.y_wall + r.side * 0.5 * t);
    const V2 dir(-hs * std::cos(ang), r.side * std::sin(ang));
    slab(b, hinge + 0.01 * dir, hinge + (P.door_width - 0.02) * dir, 0.04, 0.0,
         P.door_height - 0.01, Material::Door);
    furnishRoom(b, r, P, mc, rng, n_objects);
  }
  // Corridor: cabinets and plants against the walls between doors.
  for (double x = 1.5; x < L.length - 1.0; x += rng.uniform(3.0, 5.0)) {
    const int side = rng.bernoulli(0.5) ? 1 : -1;
    bool near_door = false;
    for (const auto& r : L.rooms)
      if (r.side == side && std::fabs(r.door_x - x) < 0.5 * P.door_width + 0.9) near_door = true;
    if (near_door) continue;
    const V2 c(x, side * (hw - 0.5 * t - 0.25));
    if (rng.bernoulli(0.5)) {  // cabinet frame: back at +y, towards the wall
      detail::addCabinet(b, pose2(V2(x, side * (hw - 0.5 * t - 0.4)), 0, side > 0 ? 0.0 : M_PI),
                         0.9, 0.4, 1.0);
    } else {
      b.cylinder(pose2(c, 0, 0), 0.18, 0.22, 0.4, 10, Material::Plastic);
      b.blob(pose2(c, 0.8, 0), V3(0.3, 0.3, 0.45), 1, 0.3, rng.next(), Material::Foliage);
    }
    ++n_objects;
  }
  GeneratedScene g;
  g.mesh = std::move(mesh);
  g.mesh.mesh.name = "indoor floor";
  g.bounds = Eigen::AlignedBox3d(V3(0, y_s, 0), V3(L.length, y_n, H));
  g.ground = HeightMap(-t, y_s - t, 1.0, 2, 2, 0.0);
  g.description = "indoor floor: " + std::to_string(L.rooms.size()) + " rooms, " +
                  std::to_string(n_objects) + " clutter objects, " +
                  std::to_string(g.mesh.numFaces()) + " triangles (seed " + std::to_string(P.seed) +
                  ")";
  OBM_LOG_INFO("sim", g.description);
  return g;
}

GeneratedScene generateRoomAroundTrajectory(const IndoorSceneParams& P, const Trajectory& cam,
                                            double floor_z) {
  if (cam.empty()) throw ConfigError("indoor room: the trajectory '" + cam.source + "' is empty");
  // Footprint of the camera path.
  Eigen::AlignedBox3d bb;
  for (const auto& T : cam.poses) bb.extend(T.translation());
  const double H = std::max(P.wall_height, bb.max().z() - floor_z + 0.6);
  const double desk_h = 0.74;
  // Where the camera looks: the optical axes meet the desk plane; their median is the desk.
  std::vector<double> fx, fy;
  for (std::size_t k = 0; k < cam.size(); k += std::max<std::size_t>(1, cam.size() / 400)) {
    const V3 o = cam.poses[k].translation(), d = cam.poses[k].linear().col(2);
    if (d.z() > -0.15) continue;  // not looking down enough to see the desk
    const double s = (floor_z + desk_h - o.z()) / d.z();
    if (s <= 0 || s > 4.0) continue;
    fx.push_back(o.x() + s * d.x());
    fy.push_back(o.y() + s * d.y());
  }
  V2 focus(bb.center().x(), bb.center().y());
  if (!fx.empty()) {
    std::nth_element(fx.begin(), fx.begin() + fx.size() / 2, fx.end());
    std::nth_element(fy.begin(), fy.begin() + fy.size() / 2, fy.end());
    focus = V2(fx[fx.size() / 2], fy[fy.size() / 2]);
  }
  // Mean horizontal viewing direction: the desk's long side faces it.
  V2 view(0, 0);
  for (const auto& T : cam.poses) view += V2(T.linear()(0, 2), T.linear()(1, 2));
  const double yaw = view.norm() > 1e-6 ? std::atan2(view.y(), view.x()) : 0.0;

  // Room: encloses the trajectory and the desk with margins.
  Eigen::AlignedBox2d room(V2(bb.min().x(), bb.min().y()), V2(bb.max().x(), bb.max().y()));
  room.extend(focus);
  room.min() -= V2::Constant(P.room_margin);
  room.max() += V2::Constant(P.room_margin);
  for (int k = 0; k < 2; ++k)
    if (room.sizes()[k] < P.min_room_size) {
      const double c = room.center()[k];
      room.min()[k] = c - 0.5 * P.min_room_size;
      room.max()[k] = c + 0.5 * P.min_room_size;
    }
  SceneMesh mesh;
  MeshBuilder b(mesh);
  Rng rng(hashSeed(P.seed, 0x700));
  const MeshClutter mc(P, rng);
  const double t = P.wall_thickness, x0 = room.min().x(), y0 = room.min().y(), x1 = room.max().x(),
               y1 = room.max().y();
  b.aabb(V3(x0 - t, y0 - t, floor_z - 0.1), V3(x1 + t, y1 + t, floor_z), Material::Floor);
  b.aabb(V3(x0 - t, y0 - t, floor_z + H + 0.001), V3(x1 + t, y1 + t, floor_z + H + 0.1),
         Material::Ceiling);
  Iso Tf = Iso::Identity();
  Tf.translation() = V3(0, 0, floor_z);
  // Walls (built at z = 0 and lifted): windows on one long wall, a door on another.
  SceneMesh walls;
  MeshBuilder bw(walls);
  const double W = x1 - x0, D = y1 - y0;
  wall(bw, V2(x0, y0), V2(1, 0), W, t, H,
       {{0.3 * W, 0.3 * W + 1.4, 0.9, 2.2, true}, {0.65 * W, 0.65 * W + 1.4, 0.9, 2.2, true}});
  wall(bw, V2(x0, y1), V2(1, 0), W, t, H,
       {{0.2 * W, 0.2 * W + P.door_width, 0.0, P.door_height, false}});
  wall(bw, V2(x0, y0), V2(0, 1), D, t, H, {});
  wall(bw, V2(x1, y0), V2(0, 1), D, t, H, {});
  walls.transform(Tf);
  mesh.append(walls);

  // Furniture keeps clear of the person holding the camera (no camera position within 0.5 m
  // horizontally, or above the desk only when at least 0.25 m higher than what is on it) and of
  // other furniture (occupancy raster).
  detail::Occupancy occ(x0, y0, x1, y1, 0.05);
  auto camera_clear = [&](const V2& c, const V2& half, double yaw, double margin) {
    const double cs = std::cos(yaw), sn = std::sin(yaw);
    for (std::size_t k = 0; k < cam.size(); k += 3) {
      const V3 p = cam.poses[k].translation();
      const V2 q(p.x() - c.x(), p.y() - c.y());
      const double lx = cs * q.x() + sn * q.y(), ly = -sn * q.x() + cs * q.y();
      if (std::fabs(lx) < half.x() + margin && std::fabs(ly) < half.y() + margin) return false;
    }
    return true;
  };
  auto place = [&](const V2& c, const V2& half, double yaw, double margin = 0.5) {
    if (c.x() - half.norm() < x0 + 0.5 * t - 0.6 || c.x() + half.norm() > x1 - 0.5 * t + 0.6 ||
        c.y() - half.norm() < y0 + 0.5 * t - 0.6 || c.y() + half.norm() > y1 - 0.5 * t + 0.6)
      return false;
    if (!occ.isFree(c, half, yaw, 0.05) || !camera_clear(c, half, yaw, margin)) return false;
    occ.mark(c, half, yaw);
    return true;
  };
  SceneMesh furn;
  MeshBuilder bf(furn);
  std::size_t n_objects = 0;
  // The desk with monitor, keyboard, books and clutter, where the cameras look (the cameras may
  // be above it).
  const double dl = 1.8, dw = 0.9;
  const Iso Td = pose2(focus, 0, yaw + M_PI_2);  // desk x across the viewing direction
  occ.mark(focus, V2(0.5 * dl, 0.5 * dw), yaw + M_PI_2);
  detail::addTable(bf, Td, dl, dw, desk_h);
  // Desk frame: +y points back at the cameras; the monitor stands at the far edge facing them.
  detail::addMonitor(bf, Td * Iso(Eigen::Translation3d(0.0, -0.3, desk_h)) *
                             Iso(Eigen::AngleAxisd(-M_PI_2, V3::UnitZ())));
  bf.box(Td * Iso(Eigen::Translation3d(0.0, 0.05, desk_h + 0.015)), V3(0.45, 0.15, 0.03),
         Material::Plastic);  // keyboard
  const int n = static_cast<int>(std::round(1.5 * P.clutter_per_room));
  for (int k = 0; k < n; ++k) {
    const V3 q = Td * V3(rng.uniform(-0.45, 0.45) * dl, rng.uniform(-0.4, 0.4) * dw, desk_h);
    clutterAt(bf, mc, V2(q.x(), q.y()), desk_h, rng);
    ++n_objects;
  }
  // Chairs by the desk.
  for (int k = 0; k < 4; ++k) {
    const V3 q = Td * V3(rng.uniform(-0.6, 0.6), (k % 2 ? 1 : -1) * (0.5 * dw + 0.4), 0);
    const double a = rng.uniform(0, 2 * M_PI);
    if (place(V2(q.x(), q.y()), V2(0.25, 0.25), a))
      detail::addChair(bf, pose2(V2(q.x(), q.y()), 0, a)), ++n_objects;
  }
  // Shelves and cabinets along all four walls (frames: back at +y, against the wall).
  for (int wall_id = 0; wall_id < 4; ++wall_id) {
    const bool horiz = wall_id < 2;
    const double len_wall = horiz ? W : D;
    for (double a = 0.6; a < len_wall - 0.6;) {
      const double len = rng.uniform(0.8, 1.4);
      const bool shelf = rng.bernoulli(0.5);
      const double depth = shelf ? 0.36 : 0.44;
      V2 front;
      double face;
      switch (wall_id) {
        case 0:
          front = V2(x0 + a + 0.5 * len, y0 + 0.5 * t + depth), face = M_PI;
          break;
        case 1:
          front = V2(x0 + a + 0.5 * len, y1 - 0.5 * t - depth), face = 0.0;
          break;
        case 2:
          front = V2(x0 + 0.5 * t + depth, y0 + a + 0.5 * len), face = M_PI_2;
          break;
        default:
          front = V2(x1 - 0.5 * t - depth, y0 + a + 0.5 * len), face = -M_PI_2;
          break;
      }
      const Iso Tf2 = pose2(front, 0, face);
      const V3 mid = Tf2 * V3(0, 0.5 * depth, 0);
      if (rng.bernoulli(0.75) && place(V2(mid.x(), mid.y()), V2(0.5 * len, 0.5 * depth), face)) {
        if (shelf)
          detail::addShelf(bf, Tf2, len, depth, rng.uniform(1.6, 2.0), 4, rng);
        else {
          detail::addCabinet(bf, Tf2, len, depth, 0.85);
          for (int k = 0; k < 2; ++k) {
            const V3 q = Tf2 * V3(rng.uniform(-0.4, 0.4) * len, 0.5 * depth, 0);
            clutterAt(bf, mc, V2(q.x(), q.y()), 0.85, rng);
          }
        }
        ++n_objects;
        a += len + rng.uniform(0.1, 0.8);
      } else {
        a += 0.5;
      }
    }
  }
  // Things on the floor around the desk (boxes, bins, plants, a low cabinet) so that views of
  // the floor are not a bare plane.
  for (int k = 0, placed = 0; k < 200 && placed < 10; ++k) {
    const double r = rng.uniform(0.8, 3.5), a = rng.uniform(0, 2 * M_PI);
    const V2 c = focus + r * V2(std::cos(a), std::sin(a));
    const double yaw_o = rng.uniform(0, M_PI);
    const int kind = static_cast<int>(rng.index(4));
    const V2 half = kind == 3 ? V2(0.4, 0.22) : V2(0.2, 0.2);
    if (!place(c, half, yaw_o, 0.35)) continue;
    ++placed;
    ++n_objects;
    const Iso To = pose2(c, 0, yaw_o);
    if (kind == 0) {  // a stack of boxes
      const double h1 = rng.uniform(0.2, 0.45);
      bf.box(To * Iso(Eigen::Translation3d(0, 0, 0.5 * h1)), V3(0.38, 0.36, h1), Material::Clutter);
      if (rng.bernoulli(0.5))
        bf.box(To * Iso(Eigen::Translation3d(0.02, 0.01, h1 + 0.12)) *
                   Iso(Eigen::AngleAxisd(rng.uniform(-0.4, 0.4), V3::UnitZ())),
               V3(0.3, 0.26, 0.24), Material::Clutter);
    } else if (kind == 1) {  // a bin
      bf.cylinder(To, 0.15, 0.18, 0.4, 14, Material::Plastic);
    } else if (kind == 2) {  // a potted plant
      bf.cylinder(To, 0.13, 0.17, 0.3, 12, Material::Plastic);
      bf.blob(To * Iso(Eigen::Translation3d(0, 0, 0.6)), V3(0.25, 0.25, 0.35), 1, 0.3, rng.next(),
              Material::Foliage);
    } else {  // a low cabinet with something on it
      detail::addCabinet(bf, To * Iso(Eigen::Translation3d(0, -0.22, 0)), 0.8, 0.44, 0.6);
      clutterAt(bf, mc, c, 0.6, rng);
    }
  }
  // A second table with chairs and clutter somewhere free.
  for (int attempt = 0; attempt < 40; ++attempt) {
    const V2 c(rng.uniform(x0 + 1.0, x1 - 1.0), rng.uniform(y0 + 1.0, y1 - 1.0));
    const double a = rng.uniform(0, M_PI);
    if (!place(c, V2(0.6, 0.4), a)) continue;
    detail::addTable(bf, pose2(c, 0, a), 1.2, 0.8, 0.72);
    for (int k = 0; k < 3; ++k)
      clutterAt(bf, mc, c + V2(rng.uniform(-0.35, 0.35), rng.uniform(-0.25, 0.25)), 0.72, rng);
    for (int k = 0; k < 2; ++k) {
      const V2 q = c + (k ? 1.0 : -1.0) * 0.85 * V2(std::cos(a), std::sin(a));
      if (place(q, V2(0.25, 0.25), a)) detail::addChair(bf, pose2(q, 0, a + (k ? M_PI : 0.0)));
    }
    n_objects += 4;
    break;
  }
  furn.transform(Tf);
  mesh.append(furn);

  GeneratedScene g;
  g.mesh = std::move(mesh);
  g.mesh.mesh.name = "room";
  g.bounds = Eigen::AlignedBox3d(V3(x0, y0, floor_z), V3(x1, y1, floor_z + H));
  g.ground = HeightMap(x0, y0, 1.0, 2, 2, floor_z);
  g.description = "room " + std::to_string(W).substr(0, 4) + " m × " +
                  std::to_string(D).substr(0, 4) + " m around '" + cam.source + "', desk at (" +
                  std::to_string(focus.x()).substr(0, 5) + ", " +
                  std::to_string(focus.y()).substr(0, 5) + "), " + std::to_string(n_objects) +
                  " objects, " + std::to_string(g.mesh.numFaces()) + " triangles";
  OBM_LOG_INFO("sim", g.description);
  return g;
}

}  // namespace obm::sim
