#include "props.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace obm::sim::detail {

namespace {
using V3 = Eigen::Vector3d;
using Iso = Eigen::Isometry3d;

Iso translate(double x, double y, double z) {
  return Iso(Eigen::Translation3d(x, y, z));
}
Iso rotZ(double a) {
  return Iso(Eigen::AngleAxisd(a, V3::UnitZ()));
}
Iso rotX(double a) {
  return Iso(Eigen::AngleAxisd(a, V3::UnitX()));
}

// Box between two corners given in the frame T.
void localBox(MeshBuilder& b, const Iso& T, const V3& lo, const V3& hi, Material m) {
  b.box(T * translate(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0.5 * (lo.z() + hi.z())),
        hi - lo, m);
}

// Quad in the facade plane y = 0 (facing −y) of frame T.
void wallQuad(MeshBuilder& b, const Iso& T, double x0, double x1, double z0, double z1,
              Material m) {
  if (x1 - x0 < 1e-6 || z1 - z0 < 1e-6) return;
  b.quad(T * V3(x0, 0, z0), T * V3(x1, 0, z0), T * V3(x1, 0, z1), T * V3(x0, 0, z1), m);
}

// A rectangular opening [x0,x1]×[z0,z1] recessed by d: back pane and the four reveals, all
// facing the street side.
void recess(MeshBuilder& b, const Iso& T, double x0, double x1, double z0, double z1, double d,
            Material back, Material side) {
  b.quad(T * V3(x0, d, z0), T * V3(x1, d, z0), T * V3(x1, d, z1), T * V3(x0, d, z1), back);
  b.quad(T * V3(x0, 0, z0), T * V3(x0, d, z0), T * V3(x0, d, z1), T * V3(x0, 0, z1), side);
  b.quad(T * V3(x1, 0, z0), T * V3(x1, 0, z1), T * V3(x1, d, z1), T * V3(x1, d, z0), side);
  b.quad(T * V3(x0, 0, z0), T * V3(x1, 0, z0), T * V3(x1, d, z0), T * V3(x0, d, z0), side);
  b.quad(T * V3(x0, 0, z1), T * V3(x0, d, z1), T * V3(x1, d, z1), T * V3(x1, 0, z1), side);
}

struct Opening {
  double x0, x1, z0, z1;
  Material back;
  double depth;
};

// One storey band [zs, ze] of a facade with its openings (sorted, non-overlapping in x).
void storey(MeshBuilder& b, const Iso& T, double width, double zs, double ze,
            std::vector<Opening> ops) {
  std::sort(ops.begin(), ops.end(), [](const Opening& a, const Opening& c) { return a.x0 < c.x0; });
  double x = 0.0;
  for (const auto& o : ops) {
    wallQuad(b, T, x, o.x0, zs, ze, Material::Facade);       // pier left of the opening
    wallQuad(b, T, o.x0, o.x1, zs, o.z0, Material::Facade);  // below
    wallQuad(b, T, o.x0, o.x1, o.z1, ze, Material::Facade);  // above
    recess(b, T, o.x0, o.x1, o.z0, o.z1, o.depth, o.back, Material::Facade);
    x = o.x1;
  }
  wallQuad(b, T, x, width, zs, ze, Material::Facade);
}

bool hasBalcony(int pattern, int bay, int bays) {
  switch (pattern) {
    case 1:
      return true;
    case 2:
      return bay % 2 == 1;
    case 3:
      return bays >= 3 && std::abs(2 * bay + 1 - bays) <= 2;
    default:
      return false;
  }
}

// A facade in frame T: x ∈ [0, width] along it, plane y = 0, outward −y, from z_base to the
// eaves. `detailed`: balconies, a cornice and an entrance; `windows`: false gives a plain wall.
void facade(MeshBuilder& b, const Iso& T, double width, double z_base, const BuildingStyle& s,
            bool detailed, bool windows, Rng& rng) {
  const double H = s.height();
  wallQuad(b, T, 0, width, z_base, 0.0, Material::Facade);  // plinth below ground level
  if (!windows || width < s.bay_width) {
    wallQuad(b, T, 0, width, 0.0, H, Material::Facade);
    return;
  }
  const int bays = std::max(1, static_cast<int>(width / s.bay_width));
  const double bw = width / bays;
  const double ww = std::min(s.window_width, 0.7 * bw);
  // Ground floor: shop windows, or ordinary windows, and an entrance door in one bay.
  const int door_bay =
      detailed ? static_cast<int>(rng.index(static_cast<std::uint64_t>(bays))) : -1;
  {
    std::vector<Opening> ops;
    for (int k = 0; k < bays; ++k) {
      const double xc = (k + 0.5) * bw;
      if (k == door_bay) {
        ops.push_back({xc - 0.6, xc + 0.6, 0.0, 2.3, Material::Door, 0.6});
      } else if (s.shop_front && detailed) {
        ops.push_back(
            {xc - 0.42 * bw, xc + 0.42 * bw, 0.45, s.ground_height - 0.6, Material::Glass, 0.3});
      } else {
        ops.push_back({xc - ww / 2, xc + ww / 2, s.sill,
                       std::min(s.sill + s.window_height, s.ground_height - 0.3), Material::Glass,
                       s.recess});
      }
    }
    storey(b, T, width, 0.0, s.ground_height, ops);
  }
  for (int f = 1; f < s.floors; ++f) {
    const double zs = s.ground_height + (f - 1) * s.floor_height, ze = zs + s.floor_height;
    std::vector<Opening> ops;
    for (int k = 0; k < bays; ++k) {
      const double xc = (k + 0.5) * bw;
      const bool balcony = detailed && hasBalcony(s.balcony_pattern, k, bays);
      // A French window opens onto a balcony; otherwise a window above the sill.
      const double z0 = balcony ? zs + 0.05 : zs + s.sill;
      const double z1 = std::min(zs + s.sill + s.window_height, ze - 0.3);
      ops.push_back({xc - ww / 2, xc + ww / 2, z0, z1, Material::Glass, s.recess});
      if (balcony) {
        const double hw = ww / 2 + 0.5, d = s.balcony_depth;
        localBox(b, T, {xc - hw, -d, zs - 0.18}, {xc + hw, 0.0, zs}, Material::Balcony);
        localBox(b, T, {xc - hw, -d, zs}, {xc + hw, -d + 0.06, zs + 1.0}, Material::Balcony);
        localBox(b, T, {xc - hw, -d + 0.06, zs}, {xc - hw + 0.05, 0.0, zs + 1.0}, Material::Metal);
        localBox(b, T, {xc + hw - 0.05, -d + 0.06, zs}, {xc + hw, 0.0, zs + 1.0}, Material::Metal);
      }
    }
    storey(b, T, width, zs, ze, ops);
  }
  if (detailed && s.floors > 1)  // string course above the ground floor
    localBox(b, T, {0.0, -0.25, s.ground_height - 0.3}, {width, 0.0, s.ground_height},
             Material::Balcony);
}
}  // namespace

BuildingStyle randomBuildingStyle(Rng& rng, int min_floors, int max_floors) {
  BuildingStyle s;
  s.floors = min_floors + static_cast<int>(rng.index(static_cast<std::uint64_t>(
                              std::max(1, max_floors - min_floors + 1))));
  s.floor_height = rng.uniform(2.9, 3.3);
  s.ground_height = rng.uniform(3.4, 4.3);
  s.bay_width = rng.uniform(2.6, 3.8);
  s.window_width = rng.uniform(1.1, 1.6);
  s.window_height = rng.uniform(1.3, 1.8);
  s.sill = rng.uniform(0.8, 1.0);
  s.recess = rng.uniform(0.15, 0.35);
  s.balcony_pattern = static_cast<int>(rng.index(4));
  s.balcony_depth = rng.uniform(0.9, 1.5);
  s.shop_front = rng.bernoulli(0.45);
  s.gable_roof = rng.bernoulli(0.4);
  s.roof_height = rng.uniform(2.5, 4.5);
  s.parapet = rng.uniform(0.5, 1.1);
  return s;
}

void addBuilding(MeshBuilder& b, const Iso& T, double W, double D, double z_base,
                 const BuildingStyle& s, bool party_walls, std::uint64_t seed) {
  Rng rng(seed);
  const double H = s.height();
  facade(b, T, W, z_base, s, true, true, rng);
  facade(b, T * translate(W, D, 0) * rotZ(M_PI), W, z_base, s, false, true, rng);
  facade(b, T * translate(0, D, 0) * rotZ(-M_PI_2), D, z_base, s, false, !party_walls, rng);
  facade(b, T * translate(W, 0, 0) * rotZ(M_PI_2), D, z_base, s, false, !party_walls, rng);
  if (s.gable_roof) {
    const double r = s.roof_height;
    b.quad(T * V3(0, 0, H), T * V3(W, 0, H), T * V3(W, D / 2, H + r), T * V3(0, D / 2, H + r),
           Material::Roof);
    b.quad(T * V3(W, D, H), T * V3(0, D, H), T * V3(0, D / 2, H + r), T * V3(W, D / 2, H + r),
           Material::Roof);
    b.triangle(T * V3(0, D, H), T * V3(0, 0, H), T * V3(0, D / 2, H + r), Material::Facade);
    b.triangle(T * V3(W, 0, H), T * V3(W, D, H), T * V3(W, D / 2, H + r), Material::Facade);
  } else {
    b.quad(T * V3(0, 0, H), T * V3(W, 0, H), T * V3(W, D, H), T * V3(0, D, H), Material::Roof);
    const double t = 0.25, p = s.parapet;
    localBox(b, T, {0, 0, H}, {W, t, H + p}, Material::Facade);
    localBox(b, T, {0, D - t, H}, {W, D, H + p}, Material::Facade);
    localBox(b, T, {0, t, H}, {t, D - t, H + p}, Material::Facade);
    localBox(b, T, {W - t, t, H}, {W, D - t, H + p}, Material::Facade);
    if (rng.bernoulli(0.5))  // a roof-top structure (stair / lift housing)
      localBox(b, T, {0.3 * W, 0.3 * D, H}, {0.3 * W + 3.0, 0.3 * D + 3.0, H + 2.6},
               Material::Facade);
  }
}

void addCar(MeshBuilder& b, const Iso& T, Rng& rng) {
  const int type = static_cast<int>(rng.index(3));  // 0 hatchback, 1 sedan, 2 van
  const double L = type == 0   ? rng.uniform(3.8, 4.2)
                   : type == 1 ? rng.uniform(4.4, 4.9)
                               : rng.uniform(4.8, 5.3);
  const double W = rng.uniform(1.7, 1.9);
  const double body_top = type == 2 ? 1.2 : 0.95;
  const double roof = type == 2 ? rng.uniform(1.9, 2.1) : rng.uniform(1.4, 1.5);
  const double r = 0.32;
  localBox(b, T, {-L / 2, -W / 2, 0.28}, {L / 2, W / 2, body_top}, Material::CarPaint);
  // Cabin: a trapezoid profile in x–z extruded across the car (prism along the local y axis).
  const double f = type == 2 ? L / 2 - 0.9 : L / 2 - 1.25,
               bk = type == 2 ? -L / 2 + 0.1 : -L / 2 + 0.55;
  const std::vector<Eigen::Vector2d> profile = {
      {bk, body_top}, {f, body_top}, {f - (type == 2 ? 0.3 : 0.6), roof}, {bk + 0.35, roof}};
  b.prism(T * rotX(M_PI_2), profile, -(W / 2 - 0.08), W / 2 - 0.08, Material::CarGlass);
  localBox(b, T, {bk + 0.4, -(W / 2 - 0.1), roof - 0.02}, {f - 0.7, W / 2 - 0.1, roof + 0.03},
           Material::CarPaint);
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2) {
      const double x = sx * (L / 2 - 0.85), y = sy * (W / 2 + 0.01);
      b.cylinder(T * translate(x, y, r) * rotX(sy > 0 ? M_PI_2 : -M_PI_2), r, r, 0.22, 10,
                 Material::Tyre);
    }
}

void addTree(MeshBuilder& b, const V3& base, Rng& rng) {
  const double trunk_h = rng.uniform(1.8, 3.2), trunk_r = rng.uniform(0.12, 0.25);
  b.cylinder(Iso(Eigen::Translation3d(base)), trunk_r, 0.7 * trunk_r, trunk_h + 0.5, 7,
             Material::TreeTrunk);
  const double rc = rng.uniform(1.6, 3.0);
  const V3 c = base + V3(0, 0, trunk_h + 0.85 * rc);
  b.blob(Iso(Eigen::Translation3d(c)), V3(rc, rc, 1.15 * rc), 1, 0.25, rng.next(),
         Material::Foliage);
  const int extra = 1 + static_cast<int>(rng.index(2));
  for (int k = 0; k < extra; ++k) {
    const double a = rng.uniform(0, 2 * M_PI), rr = rc * rng.uniform(0.5, 0.75);
    const V3 ck =
        c + V3(0.55 * rc * std::cos(a), 0.55 * rc * std::sin(a), rng.uniform(-0.3, 0.6) * rc);
    b.blob(Iso(Eigen::Translation3d(ck)), V3(rr, rr, rr), 1, 0.3, rng.next(), Material::Foliage);
  }
}

void addStreetLight(MeshBuilder& b, const V3& base, double yaw) {
  const double h = 7.0;
  b.cylinder(Iso(Eigen::Translation3d(base - V3(0, 0, 0.3))), 0.11, 0.07, h + 0.3, 8,
             Material::Metal);
  const Iso T = Iso(Eigen::Translation3d(base)) * rotZ(yaw);
  localBox(b, T, {0, -0.05, h - 0.1}, {1.6, 0.05, h}, Material::Metal);
  localBox(b, T, {1.3, -0.18, h - 0.28}, {1.9, 0.18, h - 0.08}, Material::Metal);
}

void addSign(MeshBuilder& b, const V3& base, double yaw, Rng& rng) {
  b.cylinder(Iso(Eigen::Translation3d(base - V3(0, 0, 0.3))), 0.04, 0.04, 2.9, 6, Material::Metal);
  const Iso T = Iso(Eigen::Translation3d(base)) * rotZ(yaw);
  if (rng.bernoulli(0.5))
    localBox(b, T, {-0.06, -0.35, 2.0}, {-0.03, 0.35, 2.6}, Material::Metal);
  else
    b.cylinder(T * translate(-0.05, 0, 2.3) * Iso(Eigen::AngleAxisd(M_PI_2, V3::UnitY())), 0.32,
               0.32, 0.03, 12, Material::Metal);
}

void addOrientedBox(MeshBuilder& b, const V3& a, const V3& c, double width, double z0, double z1,
                    Material m) {
  const Eigen::Vector2d d(c.x() - a.x(), c.y() - a.y());
  const double len = d.norm();
  if (len < 1e-6) return;
  Iso T = Iso::Identity();
  T.linear() = Eigen::AngleAxisd(std::atan2(d.y(), d.x()), V3::UnitZ()).toRotationMatrix();
  T.translation() = V3(0.5 * (a.x() + c.x()), 0.5 * (a.y() + c.y()), 0.5 * (z0 + z1));
  b.box(T, V3(len, width, z1 - z0), m);
}

void addWall(MeshBuilder& b, const V3& a, const V3& c, double height, double thickness,
             Material m) {
  const double zlo = std::min(a.z(), c.z()) - 0.3, zhi = 0.5 * (a.z() + c.z()) + height;
  addOrientedBox(b, a, c, thickness, zlo, zhi, m);
}

// --- indoor -----------------------------------------------------------------------------------

double addTable(MeshBuilder& b, const Iso& T, double L, double W, double h) {
  localBox(b, T, {-L / 2, -W / 2, h - 0.04}, {L / 2, W / 2, h}, Material::Wood);
  const double l = 0.05, in = 0.06;
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2) {
      const double x = sx * (L / 2 - in), y = sy * (W / 2 - in);
      localBox(b, T, {x - l / 2, y - l / 2, 0}, {x + l / 2, y + l / 2, h - 0.04}, Material::Metal);
    }
  return h;
}

void addChair(MeshBuilder& b, const Iso& T) {
  const double s = 0.44;
  localBox(b, T, {-s / 2, -s / 2, 0.43}, {s / 2, s / 2, 0.47}, Material::Fabric);
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2) {
      const double x = sx * (s / 2 - 0.03), y = sy * (s / 2 - 0.03);
      localBox(b, T, {x - 0.02, y - 0.02, 0}, {x + 0.02, y + 0.02, 0.43}, Material::Metal);
    }
  localBox(b, T, {-s / 2, -s / 2, 0.47}, {-s / 2 + 0.04, s / 2, 0.95}, Material::Fabric);
}

void addShelf(MeshBuilder& b, const Iso& T, double L, double D, double H, int levels, Rng& rng) {
  const double t = 0.02;
  localBox(b, T, {-L / 2, 0, 0}, {-L / 2 + t, D, H}, Material::Wood);
  localBox(b, T, {L / 2 - t, 0, 0}, {L / 2, D, H}, Material::Wood);
  localBox(b, T, {-L / 2 + t, D - t, 0}, {L / 2 - t, D, H}, Material::Wood);
  for (int k = 0; k <= levels; ++k) {
    const double z = k * (H - t) / levels;
    localBox(b, T, {-L / 2 + t, 0, z}, {L / 2 - t, D - t, z + t}, Material::Wood);
    if (k == levels) break;
    // Books in runs with gaps.
    double x = -L / 2 + t + rng.uniform(0.0, 0.15);
    const double zmax = (H - t) / levels - 0.04;
    while (x < L / 2 - t - 0.06) {
      if (rng.bernoulli(0.12)) {
        x += rng.uniform(0.05, 0.25);
        continue;
      }
      const double w = rng.uniform(0.02, 0.06), h = std::min(zmax, rng.uniform(0.16, 0.3));
      const double d = std::min(D - t - 0.01, rng.uniform(0.14, 0.24));
      if (x + w > L / 2 - t) break;
      localBox(b, T, {x, D - t - d, z + t}, {x + w, D - t, z + t + h},
               rng.bernoulli(0.5) ? Material::Plastic : Material::Fabric);
      x += w + 0.002;
    }
  }
}

void addCabinet(MeshBuilder& b, const Iso& T, double L, double D, double H) {
  localBox(b, T, {-L / 2, 0, 0}, {L / 2, D, H}, Material::Wood);
  localBox(b, T, {-0.02, -0.02, H * 0.4}, {0.02, 0.0, H * 0.6}, Material::Metal);  // handle
}

void addMonitor(MeshBuilder& b, const Iso& T) {
  localBox(b, T, {-0.1, -0.12, 0}, {0.1, 0.12, 0.02}, Material::Plastic);
  localBox(b, T, {-0.02, -0.03, 0.02}, {0.02, 0.03, 0.18}, Material::Plastic);
  localBox(b, T, {-0.03, -0.28, 0.12}, {0.0, 0.28, 0.46}, Material::Plastic);
}

void addSmallObject(MeshBuilder& b, const Iso& T, Rng& rng) {
  switch (rng.index(3)) {
    case 0: {
      const V3 s(rng.uniform(0.08, 0.3), rng.uniform(0.08, 0.3), rng.uniform(0.05, 0.3));
      localBox(b, T * rotZ(rng.uniform(0, M_PI)), {-s.x() / 2, -s.y() / 2, 0},
               {s.x() / 2, s.y() / 2, s.z()}, Material::Clutter);
      break;
    }
    case 1: {
      const double r = rng.uniform(0.03, 0.08);
      b.cylinder(T, r, r, rng.uniform(0.08, 0.3), 10, Material::Plastic);
      break;
    }
    default: {
      const double r = rng.uniform(0.05, 0.12);
      b.blob(T * translate(0, 0, r), V3(r, r, r), 1, 0.1, rng.next(), Material::Clutter);
    }
  }
}

}  // namespace obm::sim::detail
