// Procedural urban scenes: the street grid and the city around a given path.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include "layout.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/sim/random.hpp"
#include "obm/sim/scenes.hpp"
#include "props.hpp"

namespace obm::sim {

using detail::Occupancy;
using detail::SegmentIndex;
using detail::V2;
using V3 = Eigen::Vector3d;
using Iso = Eigen::Isometry3d;

UrbanSceneParams UrbanSceneParams::load(const ConfigNode& n) {
  UrbanSceneParams p;
  n.checkKeys({"type",
               "blocks_x",
               "blocks_y",
               "block_length_x",
               "block_length_y",
               "street_half_width",
               "sidewalk_width",
               "kerb_height",
               "block_types",
               "building_templates",
               "min_floors",
               "max_floors",
               "lot_width_min",
               "lot_width_max",
               "building_depth_min",
               "building_depth_max",
               "setback_max",
               "gap_probability",
               "car_probability",
               "tree_spacing",
               "light_spacing",
               "sign_probability",
               "margin",
               "terrain_resolution",
               "slope_x_pct",
               "slope_y_pct",
               "hill_amplitude",
               "hill_wavelength",
               "fill_spacing"});
  n.get("blocks_x", p.blocks_x);
  n.get("blocks_y", p.blocks_y);
  n.get("block_length_x", p.block_length_x);
  n.get("block_length_y", p.block_length_y);
  n.get("street_half_width", p.street_half_width);
  n.get("sidewalk_width", p.sidewalk_width);
  n.get("kerb_height", p.kerb_height);
  n.get("block_types", p.block_types);
  n.get("building_templates", p.building_templates);
  n.get("min_floors", p.min_floors);
  n.get("max_floors", p.max_floors);
  n.get("lot_width_min", p.lot_width_min);
  n.get("lot_width_max", p.lot_width_max);
  n.get("building_depth_min", p.building_depth_min);
  n.get("building_depth_max", p.building_depth_max);
  n.get("setback_max", p.setback_max);
  n.get("gap_probability", p.gap_probability);
  n.get("car_probability", p.car_probability);
  n.get("tree_spacing", p.tree_spacing);
  n.get("light_spacing", p.light_spacing);
  n.get("sign_probability", p.sign_probability);
  n.get("margin", p.margin);
  n.get("terrain_resolution", p.terrain_resolution);
  n.get("slope_x_pct", p.slope_x_pct);
  n.get("slope_y_pct", p.slope_y_pct);
  n.get("hill_amplitude", p.hill_amplitude);
  n.get("hill_wavelength", p.hill_wavelength);
  n.get("fill_spacing", p.fill_spacing);
  auto fail = [&](const char* key, const std::string& what) {
    throw ConfigError(n.where(key) + ": " + what);
  };
  if (p.blocks_x < 1) fail("blocks_x", "must be ≥ 1");
  if (p.blocks_y < 1) fail("blocks_y", "must be ≥ 1");
  if (p.street_half_width < 3.0) fail("street_half_width", "must be ≥ 3 m");
  if (p.sidewalk_width < 1.0) fail("sidewalk_width", "must be ≥ 1 m");
  const double need = 2.0 * (p.street_half_width + p.sidewalk_width + p.building_depth_max) + 6.0;
  if (p.block_length_x < need) fail("block_length_x", "must be ≥ " + std::to_string(need) + " m");
  if (p.block_length_y < need) fail("block_length_y", "must be ≥ " + std::to_string(need) + " m");
  if (p.block_types < 1) fail("block_types", "must be ≥ 1");
  if (p.building_templates < 1) fail("building_templates", "must be ≥ 1");
  if (p.min_floors < 1 || p.max_floors < p.min_floors) fail("max_floors", "need 1 ≤ min ≤ max");
  if (p.lot_width_min < 6.0 || p.lot_width_max < p.lot_width_min)
    fail("lot_width_max", "need 6 ≤ lot_width_min ≤ lot_width_max");
  if (p.building_depth_min < 5.0 || p.building_depth_max < p.building_depth_min)
    fail("building_depth_max", "need 5 ≤ building_depth_min ≤ building_depth_max");
  if (!(p.terrain_resolution > 0.1) || p.terrain_resolution > p.sidewalk_width / 2.0)
    fail("terrain_resolution", "must be in (0.1, sidewalk_width / 2]");
  if (p.tree_spacing <= 1.0) fail("tree_spacing", "must be > 1 m");
  if (p.light_spacing <= 1.0) fail("light_spacing", "must be > 1 m");
  if (p.fill_spacing <= 5.0) fail("fill_spacing", "must be > 5 m");
  return p;
}

// ---------------------------------------------------------------------------------------------
namespace {

double yawOf(const V2& d) {
  return std::atan2(d.y(), d.x());
}
V2 leftNormal(const V2& d) {
  return V2(-d.y(), d.x());
}

Iso pose2(double x, double y, double z, double yaw) {
  Iso T = Iso::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, V3::UnitZ()).toRotationMatrix();
  T.translation() = V3(x, y, z);
  return T;
}

// Points every `step` along a polyline with their unit direction.
struct Station {
  V2 p, d;
};
std::vector<Station> stations(const std::vector<V2>& line, double step, double offset0 = 0.0) {
  std::vector<Station> out;
  double carry = offset0;
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const V2 a = line[i], b = line[i + 1];
    const double L = (b - a).norm();
    if (L < 1e-9) continue;
    const V2 d = (b - a) / L;
    double s = carry;
    while (s < L) {
      out.push_back({a + s * d, d});
      s += step;
    }
    carry = s - L;
  }
  return out;
}

/// Shared machinery of both urban generators.
struct City {
  const UrbanSceneParams& P;
  SceneMesh mesh;
  MeshBuilder b{mesh};
  SegmentIndex roads{16.0};
  std::vector<std::vector<V2>> lines;
  std::function<double(double, double)> ground;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // terrain extent
  Occupancy occ;
  std::vector<detail::BuildingStyle> styles;
  std::size_t n_buildings = 0, n_cars = 0, n_trees = 0, n_poles = 0;

  explicit City(const UrbanSceneParams& p) : P(p) {
    for (int k = 0; k < P.building_templates; ++k) {
      Rng rng(hashSeed(P.seed, 0xb1d6, static_cast<std::uint64_t>(k)));
      styles.push_back(detail::randomBuildingStyle(rng, P.min_floors, P.max_floors));
    }
  }

  double w() const { return P.street_half_width; }
  double s() const { return P.sidewalk_width; }
  double roadDist(const V2& p) const { return roads.distance(p, 16.0); }

  void addLine(const std::vector<V2>& line) {
    lines.push_back(line);
    roads.addPolyline(line);
  }

  void initOccupancy() { occ = Occupancy(x0, y0, x1, y1, 0.5); }

  // Ground mesh: road level within the carriageway, raised by the kerb height beyond the middle
  // of the sidewalk (the ramp in between is hidden under the sidewalk slabs).
  void buildTerrain() {
    const double kerb = P.kerb_height, raise_at = w() + 0.5 * s();
    b.heightField(
        x0, y0, x1, y1, P.terrain_resolution,
        [&](double x, double y) {
          return ground(x, y) + (roadDist(V2(x, y)) >= raise_at ? kerb : 0.0);
        },
        [&](double x, double y) {
          const double d = roadDist(V2(x, y));
          return d < w() ? Material::Road : d < w() + s() ? Material::Sidewalk : Material::Grass;
        });
  }

  // Sidewalk slabs along both sides of every road, 2 m long, with the kerb as their road-side
  // face; pieces that would lie inside another road (intersections) are left out.
  void buildSidewalks() {
    const double kerb = P.kerb_height;
    for (const auto& line : lines) {
      for (const auto& st : stations(line, 2.0)) {
        const V2 n = leftNormal(st.d);
        for (int side = -1; side <= 1; side += 2) {
          const V2 mid = st.p + st.d * 1.0 + side * n * (w() + 0.5 * s());
          if (roadDist(mid) < w() + 0.5 * s() - 0.3) continue;
          V3 c[8];
          for (int k = 0; k < 8; ++k) {
            const double along = (k & 1) ? 2.02 : 0.0;
            const double off = (k & 2) ? w() + s() : w();
            const V2 q = st.p + along * st.d + side * off * n;
            const double z = ground(q.x(), q.y()) + ((k & 4) ? kerb : -0.3);
            c[k] = V3(q.x(), q.y(), z);
          }
          if (side < 0) {
            // Mirror: keep the corner bits' handedness (bit 1 must point to +y of a right-handed
            // frame), so swap the along-direction corners.
            for (int k = 0; k < 8; k += 2) std::swap(c[k], c[k + 1]);
          }
          b.hexahedron(c, Material::Sidewalk);
        }
      }
    }
  }

  // Parked cars, trees, street lights and signs along every road.
  void furnishStreets() {
    for (std::size_t li = 0; li < lines.size(); ++li) {
      Rng rng(hashSeed(P.seed, 0x57ee7, li));
      const auto& line = lines[li];
      for (int side = -1; side <= 1; side += 2) {
        // Parking lane.
        for (const auto& st : stations(line, 6.0, 3.0)) {
          if (!rng.bernoulli(P.car_probability)) continue;
          const V2 n = leftNormal(st.d);
          const V2 c = st.p + side * n * (w() - 1.15);
          bool ok = true;
          for (double a : {-3.2, 0.0, 3.2})
            for (double l : {-1.0, 1.0}) {
              const V2 q = c + a * st.d + l * n;
              if (roadDist(q) < w() - 2.25) ok = false;
            }
          const double yaw = yawOf(st.d) + (side < 0 ? 0.0 : M_PI);
          if (!ok || !occ.isFree(c, V2(2.6, 1.0), yaw)) {
            rng.next();  // keep the stream aligned whatever happens
            continue;
          }
          occ.mark(c, V2(2.6, 1.0), yaw);
          Rng car_rng(rng.next());
          detail::addCar(b,
                         pose2(c.x(), c.y(), ground(c.x(), c.y()), yaw + rng.uniform(-0.03, 0.03)),
                         car_rng);
          ++n_cars;
        }
        // Trees near the kerb.
        for (const auto& st : stations(line, P.tree_spacing, rng.uniform(0, P.tree_spacing))) {
          const V2 n = leftNormal(st.d);
          const V2 c = st.p + side * n * (w() + 1.1) + st.d * rng.uniform(-1.0, 1.0);
          const bool want = rng.bernoulli(0.75);
          if (!want || roadDist(c) < w() + 0.9 || !occ.isFree(c, V2(0.6, 0.6), 0.0)) continue;
          occ.mark(c, V2(0.6, 0.6), 0.0);
          detail::addTree(b, V3(c.x(), c.y(), ground(c.x(), c.y()) + P.kerb_height), rng);
          ++n_trees;
        }
        // Street lights (arm over the road) and signs.
        for (const auto& st :
             stations(line, P.light_spacing, side > 0 ? 5.0 : 5.0 + P.light_spacing / 2)) {
          const V2 n = leftNormal(st.d);
          const V2 c = st.p + side * n * (w() + 0.45);
          if (roadDist(c) < w() + 0.3 || !occ.isFree(c, V2(0.3, 0.3), 0.0)) continue;
          occ.mark(c, V2(0.3, 0.3), 0.0);
          const V3 base(c.x(), c.y(), ground(c.x(), c.y()) + P.kerb_height);
          detail::addStreetLight(b, base, yawOf(-side * n));
          ++n_poles;
          if (rng.bernoulli(P.sign_probability)) {
            const V2 q = c + st.d * 4.0;
            if (roadDist(q) >= w() + 0.3 && occ.isFree(q, V2(0.3, 0.3), 0.0)) {
              occ.mark(q, V2(0.3, 0.3), 0.0);
              detail::addSign(b, V3(q.x(), q.y(), ground(q.x(), q.y()) + P.kerb_height),
                              yawOf(side > 0 ? -st.d : st.d), rng);
              ++n_poles;
            }
          }
        }
      }
    }
  }

  // Footprint points of a building in frame (origin corner o, axes ex / ey) on a ~2 m grid.
  template <typename F>
  bool footprintAll(const V2& o, const V2& ex, const V2& ey, double W, double D, F&& pred) const {
    const int nx = std::max(1, static_cast<int>(std::ceil(W / 2.0)));
    const int ny = std::max(1, static_cast<int>(std::ceil(D / 2.0)));
    for (int i = 0; i <= nx; ++i)
      for (int j = 0; j <= ny; ++j)
        if (!pred(o + ex * (W * i / nx) + ey * (D * j / ny))) return false;
    return true;
  }

  /// A building whose footprint origin (left end of the street facade) is at `o` with the facade
  /// running along `yaw`. With `check`, it must keep `clearance` from the roads and not overlap
  /// anything; returns whether it was built.
  bool building(const V2& o, double yaw, double W, double D, int style, bool party,
                std::uint64_t seed, bool check, double clearance) {
    const V2 ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
    const V2 centre = o + 0.5 * W * ex + 0.5 * D * ey;
    if (check) {
      if (!footprintAll(o, ex, ey, W, D, [&](const V2& q) { return roadDist(q) >= clearance; }))
        return false;
      if (!occ.isFree(centre, V2(0.5 * W, 0.5 * D), yaw, 0.3)) return false;
    }
    occ.mark(centre, V2(0.5 * W, 0.5 * D), yaw);
    double zmin = 1e30;
    footprintAll(o, ex, ey, W, D, [&](const V2& q) {
      zmin = std::min(zmin, ground(q.x(), q.y()));
      return true;
    });
    const V2 front = o + 0.5 * W * ex;
    const double zf = ground(front.x(), front.y()) + P.kerb_height;
    detail::addBuilding(b, pose2(o.x(), o.y(), zf, yaw), W, D, zmin - zf - 0.5,
                        styles[static_cast<std::size_t>(style) % styles.size()], party, seed);
    ++n_buildings;
    return true;
  }

  GeneratedScene finish(const std::string& what, const HeightMap& hm) {
    GeneratedScene g;
    g.mesh = std::move(mesh);
    g.mesh.mesh.name = what;
    g.ground = hm;
    g.description = what + ": " + std::to_string(n_buildings) + " buildings, " +
                    std::to_string(n_cars) + " cars, " + std::to_string(n_trees) + " trees, " +
                    std::to_string(n_poles) + " poles, " + std::to_string(g.mesh.numFaces()) +
                    " triangles";
    OBM_LOG_INFO("sim", g.description);
    return g;
  }
};

HeightMap sampleHeightMap(double x0, double y0, double x1, double y1, double res,
                          const std::function<double(double, double)>& f) {
  const int nx = static_cast<int>(std::ceil((x1 - x0) / res)) + 1;
  const int ny = static_cast<int>(std::ceil((y1 - y0) / res)) + 1;
  HeightMap hm(x0, y0, res, nx, ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) hm.node(i, j) = static_cast<float>(f(x0 + i * res, y0 + j * res));
  return hm;
}

// One lot of a block layout, in block-local coordinates.
struct LotItem {
  enum Kind { Building, Wall, Tree } kind;
  V2 o;  // building: footprint origin; wall: start; tree: position
  V2 e;  // wall: end
  double yaw = 0, W = 0, D = 0;
  int style = 0;
  bool party = false;
  std::uint64_t seed = 0;
};

// Perimeter block development: buildings along the four sides of the block interior
// [0, Bx]×[0, By], facing outwards to the streets; gaps get a wall and a tree; trees in the yard.
std::vector<LotItem> blockLayout(const UrbanSceneParams& P, double Bx, double By, Rng& rng) {
  std::vector<LotItem> items;
  double depth[4], setback[4];
  for (int k = 0; k < 4; ++k) {
    depth[k] = rng.uniform(P.building_depth_min, P.building_depth_max);
    setback[k] = rng.uniform(0.0, P.setback_max);
  }
  // Sides: 0 south (facing −y), 1 north (+y), 2 west (−x), 3 east (+x). Side lengths and the
  // map from (along, inward) to block coordinates.
  for (int side = 0; side < 4; ++side) {
    double a0 = 0, a1 = side < 2 ? Bx : By;
    if (side >= 2) {
      a0 = depth[0] + setback[0] + 1.0;
      a1 = By - depth[1] - setback[1] - 1.0;
    }
    double a = a0;
    while (a1 - a >= P.lot_width_min) {
      double W = rng.uniform(P.lot_width_min, P.lot_width_max);
      if (a1 - a - W < P.lot_width_min) W = a1 - a;  // the last lot takes the rest
      const bool gap = rng.bernoulli(P.gap_probability);
      const double sb = setback[side], D = depth[side];
      // Footprint origin (left end of the facade seen from the street) and facade direction.
      V2 o;
      double yaw = 0;
      switch (side) {
        case 0:
          o = V2(a, sb), yaw = 0;
          break;
        case 1:
          o = V2(Bx - a, By - sb), yaw = M_PI;
          break;
        case 2:
          o = V2(sb, By - a), yaw = -M_PI_2;
          break;
        default:
          o = V2(Bx - sb, a), yaw = M_PI_2;
          break;
      }
      const V2 ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
      if (gap) {
        LotItem wall{LotItem::Wall, o - sb * ey + 0.3 * ey, o - sb * ey + 0.3 * ey + W * ex};
        items.push_back(wall);
        LotItem tree{LotItem::Tree, o + 0.5 * W * ex + 0.5 * D * ey, V2::Zero()};
        items.push_back(tree);
      } else {
        LotItem bl{LotItem::Building, o, V2::Zero(), yaw, W, D};
        bl.style = static_cast<int>(rng.index(static_cast<std::uint64_t>(P.building_templates)));
        bl.party = W < 20.0;
        bl.seed = rng.next();
        items.push_back(bl);
      }
      a += W;
    }
  }
  // Yard trees.
  const double ix0 = depth[2] + setback[2] + 3, ix1 = Bx - depth[3] - setback[3] - 3;
  const double iy0 = depth[0] + setback[0] + 3, iy1 = By - depth[1] - setback[1] - 3;
  if (ix1 > ix0 && iy1 > iy0) {
    const int n = 2 + static_cast<int>(rng.index(4));
    for (int k = 0; k < n; ++k)
      items.push_back(
          {LotItem::Tree, V2(rng.uniform(ix0, ix1), rng.uniform(iy0, iy1)), V2::Zero()});
  }
  return items;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

GeneratedScene generateUrbanGrid(const UrbanSceneParams& P) {
  City city(P);
  const double Lx = P.block_length_x, Ly = P.block_length_y;
  const int nx = P.blocks_x, ny = P.blocks_y;
  // Street lines of the drivable grid plus one ring of blocks around it.
  const double sx0 = -Lx, sx1 = (nx + 1) * Lx, sy0 = -Ly, sy1 = (ny + 1) * Ly;
  city.x0 = sx0 - P.margin;
  city.x1 = sx1 + P.margin;
  city.y0 = sy0 - P.margin;
  city.y1 = sy1 + P.margin;
  const double sx = P.slope_x_pct / 100.0, sy = P.slope_y_pct / 100.0, A = P.hill_amplitude,
               lam = P.hill_wavelength;
  city.ground = [=](double x, double y) {
    return sx * x + sy * y +
           A * std::sin(2 * M_PI * x / lam) * std::cos(2 * M_PI * y / (1.3 * lam));
  };
  for (int i = -1; i <= nx + 1; ++i) city.addLine({V2(i * Lx, sy0), V2(i * Lx, sy1)});
  for (int j = -1; j <= ny + 1; ++j) city.addLine({V2(sx0, j * Ly), V2(sx1, j * Ly)});
  city.initOccupancy();

  // Blocks: identical layouts per block type.
  const double inset = P.street_half_width + P.sidewalk_width;
  const double Bx = Lx - 2 * inset, By = Ly - 2 * inset;
  std::map<int, std::vector<LotItem>> layouts;
  for (int t = 0; t < P.block_types; ++t) {
    Rng rng(hashSeed(P.seed, 0xb10c, static_cast<std::uint64_t>(t)));
    layouts[t] = blockLayout(P, Bx, By, rng);
  }
  for (int i = -1; i <= nx; ++i)
    for (int j = -1; j <= ny; ++j) {
      const int type =
          static_cast<int>(hashSeed(P.seed, 0x7e9e, static_cast<std::uint64_t>(i + 1000),
                                    static_cast<std::uint64_t>(j + 1000)) %
                           static_cast<std::uint64_t>(P.block_types));
      const V2 origin(i * Lx + inset, j * Ly + inset);
      Rng tree_rng(hashSeed(P.seed, 0x7ee, static_cast<std::uint64_t>(type)));
      for (const LotItem& it : layouts[type]) {
        switch (it.kind) {
          case LotItem::Building:
            city.building(origin + it.o, it.yaw, it.W, it.D, it.style, it.party, it.seed, false,
                          0.0);
            break;
          case LotItem::Wall: {
            const V2 a = origin + it.o, e = origin + it.e;
            detail::addWall(city.b, V3(a.x(), a.y(), city.ground(a.x(), a.y()) + P.kerb_height),
                            V3(e.x(), e.y(), city.ground(e.x(), e.y()) + P.kerb_height), 1.8, 0.3,
                            Material::Wall);
            break;
          }
          case LotItem::Tree: {
            const V2 q = origin + it.o;
            detail::addTree(city.b, V3(q.x(), q.y(), city.ground(q.x(), q.y()) + P.kerb_height),
                            tree_rng);
            city.occ.mark(q, V2(0.6, 0.6), 0.0);
            ++city.n_trees;
            break;
          }
        }
      }
    }
  city.buildTerrain();
  city.buildSidewalks();
  city.furnishStreets();
  GeneratedScene g =
      city.finish("urban grid " + std::to_string(nx) + "x" + std::to_string(ny) + " blocks (seed " +
                      std::to_string(P.seed) + ")",
                  sampleHeightMap(city.x0, city.y0, city.x1, city.y1, 1.0, city.ground));
  double zmin = 1e30, zmax = -1e30;
  for (const auto& v : g.mesh.mesh.vertices) {
    zmin = std::min(zmin, static_cast<double>(v.z()));
    zmax = std::max(zmax, static_cast<double>(v.z()));
  }
  g.bounds = Eigen::AlignedBox3d(V3(sx0, sy0, zmin - 5.0), V3(sx1, sy1, zmax + 30.0));
  return g;
}

GeneratedScene generateUrbanAroundPath(const UrbanSceneParams& P, const Trajectory& path,
                                       double sensor_height) {
  if (path.size() < 2)
    throw ConfigError("urban scene around a path: the trajectory '" + path.source +
                      "' has fewer than 2 poses");
  City city(P);
  // Road centre line: the path's ground track, thinned to ≥ 2 m spacing.
  std::vector<V2> line;
  std::vector<double> heights;
  for (const auto& T : path.poses) {
    const V3 g = T * V3(0, 0, -sensor_height);  // ground point under the sensor
    const V2 q(g.x(), g.y());
    if (line.empty() || (q - line.back()).norm() >= 2.0) {
      line.push_back(q);
      heights.push_back(g.z());
    }
  }
  if (line.size() < 2) line.push_back(line.back() + V2(0.5, 0)), heights.push_back(heights.back());
  city.lines.push_back(line);
  city.roads.addPolyline(line, heights);

  double bx0 = 1e30, by0 = 1e30, bx1 = -1e30, by1 = -1e30;
  for (const auto& q : line) {
    bx0 = std::min(bx0, q.x());
    by0 = std::min(by0, q.y());
    bx1 = std::max(bx1, q.x());
    by1 = std::max(by1, q.y());
  }
  const double reach = P.street_half_width + P.sidewalk_width + P.setback_max +
                       2.0 * P.building_depth_max + P.margin;
  city.x0 = bx0 - reach;
  city.y0 = by0 - reach;
  city.x1 = bx1 + reach;
  city.y1 = by1 + reach;
  // Ground: the height of the nearest road point, smoothed (box blur) to remove creases.
  const double res = 4.0;
  HeightMap hm = sampleHeightMap(city.x0, city.y0, city.x1, city.y1, res, [&](double x, double y) {
    double h = heights.front();
    city.roads.nearest(V2(x, y), &h);
    return h;
  });
  for (int pass = 0; pass < 2; ++pass) {
    HeightMap tmp = hm;
    for (int j = 0; j < hm.ny(); ++j)
      for (int i = 0; i < hm.nx(); ++i) {
        double s = 0;
        int n = 0;
        for (int dj = -2; dj <= 2; ++dj)
          for (int di = -2; di <= 2; ++di) {
            const int ii = std::clamp(i + di, 0, hm.nx() - 1),
                      jj = std::clamp(j + dj, 0, hm.ny() - 1);
            s += tmp.node(ii, jj);
            ++n;
          }
        hm.node(i, j) = static_cast<float>(s / n);
      }
  }
  // Re-anchor the smoothed surface on the road: within the road corridor the exact path height
  // wins, blending into the smoothed field over the next 10 m.
  const HeightMap smooth = hm;
  for (int j = 0; j < hm.ny(); ++j)
    for (int i = 0; i < hm.nx(); ++i) {
      const V2 q(hm.x0() + i * res, hm.y0() + j * res);
      double h = 0;
      const double d = city.roads.distance(q, 30.0, &h);
      const double a = std::clamp((d - P.street_half_width) / 10.0, 0.0, 1.0);
      if (d < 30.0) hm.node(i, j) = static_cast<float>((1 - a) * h + a * smooth.node(i, j));
    }
  city.ground = [&hm](double x, double y) { return hm.at(x, y); };
  city.initOccupancy();

  // Buildings along both sides of the road, then a back row on a coarse grid.
  Rng rng(hashSeed(P.seed, 0xa10, 1));
  const double front = P.street_half_width + P.sidewalk_width;
  int tries = 0, built_n = 0;
  for (int side = -1; side <= 1; side += 2) {
    double pos = 0.0, total = 0.0;
    std::vector<double> cum(1, 0.0);
    for (std::size_t k = 1; k < line.size(); ++k)
      cum.push_back(total += (line[k] - line[k - 1]).norm());
    auto at = [&](double s, V2& p, V2& d) {
      const auto it = std::upper_bound(cum.begin(), cum.end(), s);
      const std::size_t k = std::min<std::size_t>(
          line.size() - 1, static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - cum.begin())));
      d = (line[k] - line[k - 1]).normalized();
      p = line[k - 1] + (s - cum[k - 1]) * d;
    };
    while (pos < total) {
      double W = rng.uniform(P.lot_width_min, P.lot_width_max);
      const double D = rng.uniform(P.building_depth_min, P.building_depth_max);
      const double sb = rng.uniform(0.0, P.setback_max);
      const int style =
          static_cast<int>(rng.index(static_cast<std::uint64_t>(P.building_templates)));
      const std::uint64_t seed = rng.next();
      const bool gap = rng.bernoulli(P.gap_probability);
      V2 p, d;
      at(std::min(total, pos + 0.5 * W), p, d);
      const V2 n = leftNormal(d);
      // Facade towards the road: its outward normal is −side·n; local x = (side·n) × z.
      const V2 out = -side * n;
      const V2 ey = -out, ex(ey.y(), -ey.x());
      const V2 centre = p - out * (front + sb);
      const V2 o = centre - 0.5 * W * ex;
      bool built = false;
      if (!gap) built = city.building(o, yawOf(ex), W, D, style, W < 20.0, seed, true, front - 0.1);
      if (!gap && !built) {  // on a bend a narrower, shallower house may still fit
        const double w2 = P.lot_width_min, d2 = P.building_depth_min;
        built = city.building(centre - 0.5 * w2 * ex, yawOf(ex), w2, d2, style, false, seed, true,
                              front - 0.1);
        if (built) W = w2;
      }
      if (!built && rng.bernoulli(0.5)) {
        const V2 a = o + 0.3 * ey, e = a + W * ex;
        const V2 mid = 0.5 * (a + e);
        if (city.roadDist(a) > front && city.roadDist(e) > front &&
            city.occ.isFree(mid, V2(0.5 * W, 0.3), yawOf(ex))) {
          city.occ.mark(mid, V2(0.5 * W, 0.3), yawOf(ex));
          detail::addWall(city.b, V3(a.x(), a.y(), city.ground(a.x(), a.y()) + P.kerb_height),
                          V3(e.x(), e.y(), city.ground(e.x(), e.y()) + P.kerb_height), 1.6, 0.3,
                          Material::Wall);
        }
      }
      ++tries;
      built_n += built ? 1 : 0;
      pos += W + (built ? rng.uniform(0.0, 3.0) : 2.0);
    }
  }
  OBM_LOG_DEBUG("sim", "road-side lots: " << built_n << " buildings of " << tries << " lots");
  for (double y = city.y0 + 10; y < city.y1 - 10; y += P.fill_spacing)
    for (double x = city.x0 + 10; x < city.x1 - 10; x += P.fill_spacing) {
      const V2 c(x + rng.uniform(-5, 5), y + rng.uniform(-5, 5));
      V2 dir(1, 0);
      const double dist = city.roads.nearest(c, nullptr, &dir);
      const double W = rng.uniform(P.lot_width_min, P.lot_width_max);
      const double D = rng.uniform(P.building_depth_min, P.building_depth_max);
      const int style =
          static_cast<int>(rng.index(static_cast<std::uint64_t>(P.building_templates)));
      const std::uint64_t seed = rng.next();
      if (dist < front + 4.0) continue;
      const double yaw = yawOf(dir) + (rng.bernoulli(0.5) ? 0.0 : M_PI);
      const V2 ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
      if (!city.building(c - 0.5 * W * ex - 0.5 * D * ey, yaw, W, D, style, false, seed, true,
                         front + 3.0)) {
        if (rng.bernoulli(0.3) && city.occ.isFree(c, V2(0.6, 0.6), 0.0)) {
          city.occ.mark(c, V2(0.6, 0.6), 0.0);
          detail::addTree(city.b, V3(c.x(), c.y(), city.ground(c.x(), c.y()) + P.kerb_height), rng);
          ++city.n_trees;
        }
      }
    }
  city.buildTerrain();
  city.buildSidewalks();
  city.furnishStreets();

  // How well the ground follows the path (the sensor must ride sensor_height above it).
  double worst = 0.0;
  for (std::size_t k = 0; k < line.size(); ++k)
    worst = std::max(worst, std::fabs(hm.at(line[k].x(), line[k].y()) - heights[k]));
  OBM_LOG_DEBUG("sim", "ground under the path deviates by at most " << worst << " m");

  GeneratedScene g = city.finish(
      "urban corridor around '" + path.source + "' (seed " + std::to_string(P.seed) + ")", hm);
  double zmin = 1e30, zmax = -1e30;
  for (const auto& v : g.mesh.mesh.vertices) {
    zmin = std::min(zmin, static_cast<double>(v.z()));
    zmax = std::max(zmax, static_cast<double>(v.z()));
  }
  g.bounds =
      Eigen::AlignedBox3d(V3(city.x0, city.y0, zmin - 5.0), V3(city.x1, city.y1, zmax + 30.0));
  return g;
}

}  // namespace obm::sim
