#include "obm/registration/correlative_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/prepared_target.hpp"

namespace obm::registration {

void CorrelativeSearchParams::validate() const {
  if (axis != "x" && axis != "y" && axis != "z" && axis != "any")
    throw ConfigError("correlative search: axis must be x, y, z or any, not '" + axis + "'");
  if (!(max_tilt_deg >= 0.0 && max_tilt_deg < 90.0))
    throw ConfigError("correlative search: max_tilt_deg must be in [0, 90)");
  if (!(heading_range_deg >= 0.0 && heading_range_deg <= 180.0))
    throw ConfigError("correlative search: heading_range_deg must be in [0, 180]");
  if (!(heading_step_deg > 0.0))
    throw ConfigError("correlative search: heading_step_deg must be > 0");
  // Every rotation: (2·range/step + 1)³ grid points, about half of them within the range.
  if (axis == "any" && heading_range_deg / heading_step_deg > 15.0)
    throw ConfigError("correlative search: with axis any, heading_range_deg / heading_step_deg "
                      "must be <= 15 (about 14 000 rotations)");
  if (!(translation_range >= 0.0))
    throw ConfigError("correlative search: translation_range must be >= 0");
  if (!(axial_range >= 0.0 || axial_range == -1.0))
    throw ConfigError("correlative search: axial_range must be >= 0, or -1 for translation_range");
  if (!(cell > 0.0)) throw ConfigError("correlative search: cell must be > 0");
  // The translation grid has (2·range/cell + 1)³ entries per heading: keep it a search, not a
  // runaway (61³ ≈ 227 000 shifts per heading at the limit).
  if (translation_range / cell > 30.0)
    throw ConfigError("correlative search: translation_range / cell must be <= 30 (a coarser "
                      "cell or a shorter range)");
  if (!(color_tolerance >= 0.0 && color_tolerance <= 1.0))
    throw ConfigError("correlative search: color_tolerance must be in [0, 1] (0 = off)");
  if (sample_points < 0) throw ConfigError("correlative search: sample_points must be >= 0");
  if (candidates < 1) throw ConfigError("correlative search: candidates must be >= 1");
  if (shifts_per_heading < 1)
    throw ConfigError("correlative search: shifts_per_heading must be >= 1");
  if (!(min_separation_deg >= 0.0) || !(min_separation_m >= 0.0))
    throw ConfigError("correlative search: min_separation_deg / min_separation_m must be >= 0");
}

CorrelativeSearchParams CorrelativeSearchParams::load(const ConfigNode& node) {
  CorrelativeSearchParams p;
  node.checkKeys({"axis", "axis_from_floor", "max_tilt_deg", "heading_range_deg",
                  "heading_step_deg", "translation_range", "axial_range", "align_centroids", "cell",
                  "sample_points", "candidates", "shifts_per_heading", "min_separation_deg",
                  "min_separation_m", "color_tolerance", "seed"});
  node.get("axis", p.axis);
  node.get("axis_from_floor", p.axis_from_floor);
  node.get("max_tilt_deg", p.max_tilt_deg);
  node.get("heading_range_deg", p.heading_range_deg);
  node.get("heading_step_deg", p.heading_step_deg);
  node.get("translation_range", p.translation_range);
  node.get("axial_range", p.axial_range);
  node.get("align_centroids", p.align_centroids);
  node.get("cell", p.cell);
  node.get("sample_points", p.sample_points);
  node.get("candidates", p.candidates);
  node.get("shifts_per_heading", p.shifts_per_heading);
  node.get("min_separation_deg", p.min_separation_deg);
  node.get("min_separation_m", p.min_separation_m);
  node.get("color_tolerance", p.color_tolerance);
  node.get("seed", p.seed);
  try {
    p.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.where("") + ": " + e.what());
  }
  return p;
}

namespace {

/// Occupancy of the target on a grid of cell c, padded by `pad` cells on every side so that a
/// source cell shifted by up to `pad` cells always lands inside. Values: 2 in an occupied cell,
/// 1 next to one (26-neighbourhood), 0 elsewhere — a blurred occupancy, so that a point a little
/// off its surface still counts half while the search steps by whole cells.
struct OccupancyField {
  double cell = 0.1;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< corner of cell (0, 0, 0) [m]
  std::array<int, 3> dims{0, 0, 0};
  std::vector<std::uint8_t> value;
  /// With colours: the mean grey level (0–255) of the target points in each occupied cell.
  std::vector<std::uint8_t> grey;

  std::int64_t index(int x, int y, int z) const {
    return (static_cast<std::int64_t>(z) * dims[1] + y) * dims[0] + x;
  }

  OccupancyField(const std::vector<Vector3f>& points, double c, int pad,
                 const std::vector<std::uint8_t>* point_grey = nullptr)
      : cell(c) {
    Eigen::Vector3d lo = points.front().cast<double>(), hi = lo;
    for (const auto& p : points) {
      lo = lo.cwiseMin(p.cast<double>());
      hi = hi.cwiseMax(p.cast<double>());
    }
    origin = lo - Eigen::Vector3d::Constant((pad + 1) * c);
    for (int a = 0; a < 3; ++a)
      dims[a] = static_cast<int>(std::floor((hi[a] - lo[a]) / c)) + 2 * (pad + 1) + 1;
    value.assign(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2], 0);
    std::vector<std::int64_t> occupied;
    for (const auto& p : points) {
      const auto k = cellOf(p.cast<double>());
      const std::int64_t i = index(k[0], k[1], k[2]);
      if (value[static_cast<std::size_t>(i)] == 0) occupied.push_back(i);
      value[static_cast<std::size_t>(i)] = 2;
    }
    if (point_grey) {
      std::unordered_map<std::int64_t, std::pair<std::uint32_t, std::uint32_t>> sums;
      for (std::size_t j = 0; j < points.size(); ++j) {
        const auto k = cellOf(points[j].cast<double>());
        auto& acc = sums[index(k[0], k[1], k[2])];
        acc.first += (*point_grey)[j];
        ++acc.second;
      }
      grey.assign(value.size(), 0);
      for (const auto& kv : sums)
        grey[static_cast<std::size_t>(kv.first)] =
            static_cast<std::uint8_t>((kv.second.first + kv.second.second / 2) / kv.second.second);
    }
    for (const std::int64_t i : occupied) {
      const int x = static_cast<int>(i % dims[0]);
      const int y = static_cast<int>((i / dims[0]) % dims[1]);
      const int z = static_cast<int>(i / (static_cast<std::int64_t>(dims[0]) * dims[1]));
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int u = x + dx, v = y + dy, w = z + dz;
            if (u < 0 || v < 0 || w < 0 || u >= dims[0] || v >= dims[1] || w >= dims[2]) continue;
            auto& val = value[static_cast<std::size_t>(index(u, v, w))];
            val = std::max<std::uint8_t>(val, 1);
          }
    }
  }

  std::array<int, 3> cellOf(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = (p - origin) / cell;
    return {static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
            static_cast<int>(std::floor(q.z()))};
  }
};

/// Score of the points (cells already computed, -1 = outside the reach of any shift) shifted by
/// `shift` cells: the sum of the field's values. With `grey` (the scored points' grey levels,
/// 0–255) and a field with colours, a point in an occupied cell whose grey differs from the
/// cell's by more than `tolerance` counts as one next to it: a slide along a textured wall keeps
/// its points on the wall, not on its texture.
std::int64_t scoreShift(const OccupancyField& f, const std::vector<std::int64_t>& base,
                        const std::array<int, 3>& shift,
                        const std::vector<std::uint8_t>* grey = nullptr, int tolerance = 0) {
  const std::int64_t off =
      (static_cast<std::int64_t>(shift[2]) * f.dims[1] + shift[1]) * f.dims[0] + shift[0];
  std::int64_t s = 0;
  if (!grey || f.grey.empty()) {
    for (const std::int64_t b : base)
      if (b >= 0) s += f.value[static_cast<std::size_t>(b + off)];
    return s;
  }
  for (std::size_t i = 0; i < base.size(); ++i) {
    if (base[i] < 0) continue;
    const auto c = static_cast<std::size_t>(base[i] + off);
    const std::uint8_t v = f.value[c];
    s += v == 2 && std::abs(static_cast<int>(f.grey[c]) - static_cast<int>((*grey)[i])) > tolerance
             ? 1
             : v;
  }
  return s;
}

/// The cells of `points` in `f`, or −1 where a shift of up to `reach` cells cannot bring the
/// point inside the grid.
std::vector<std::int64_t> baseCells(const OccupancyField& f, const std::vector<Eigen::Vector3d>& pts,
                                    int reach) {
  std::vector<std::int64_t> out(pts.size(), -1);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto k = f.cellOf(pts[i]);
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && k[a] - reach >= 0 && k[a] + reach < f.dims[a];
    if (inside) out[i] = f.index(k[0], k[1], k[2]);
  }
  return out;
}

/// floorNormal at one patch size.
std::optional<Eigen::Vector3d> floorNormalAt(const std::vector<Vector3f>& points, double cell,
                                             const Eigen::Vector3d& nominal, double max_tilt_deg) {
  struct Moments {
    int n = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  };
  std::unordered_map<std::int64_t, Moments> cells;
  for (const auto& p : points) {
    const Eigen::Vector3d q = p.cast<double>();
    const auto k = [&](int a) { return static_cast<std::int64_t>(std::floor(q[a] / cell)); };
    // 21 bits per axis: ±10⁶ cells, far beyond any sensor's range at a useful cell.
    const std::int64_t key =
        ((k(0) & 0x1FFFFF) << 42) | ((k(1) & 0x1FFFFF) << 21) | (k(2) & 0x1FFFFF);
    Moments& m = cells[key];
    ++m.n;
    m.sum += q;
    m.outer += q * q.transpose();
  }
  // Each patch's normal: the direction of least spread, kept when the patch is thin (its
  // smallest eigenvalue under a tenth of the middle one).
  std::vector<std::pair<Eigen::Vector3d, double>> normals;
  for (const auto& kv : cells) {
    const Moments& m = kv.second;
    if (m.n < 6) continue;
    const Eigen::Vector3d mean = m.sum / m.n;
    const Eigen::Matrix3d cov = m.outer / m.n - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    if (!(es.eigenvalues()(0) < 0.1 * es.eigenvalues()(1))) continue;
    normals.emplace_back(es.eigenvectors().col(0), static_cast<double>(m.n));
  }
  if (normals.empty()) return std::nullopt;
  const Eigen::Vector3d a = nominal.normalized();
  const double cos_tilt = std::cos(max_tilt_deg * M_PI / 180.0);
  const double cos_window = std::cos(10.0 * M_PI / 180.0);
  Eigen::Vector3d v = a;
  std::size_t support = 0;
  for (int it = 0; it < 10; ++it) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    support = 0;
    for (const auto& [n, w] : normals) {
      const Eigen::Vector3d s = n.dot(a) < 0.0 ? Eigen::Vector3d(-n) : n;
      if (s.dot(a) < cos_tilt || s.dot(v) < cos_window) continue;
      sum += w * s;
      ++support;
    }
    if (support == 0) return std::nullopt;
    const Eigen::Vector3d next = sum.normalized();
    const bool settled = next.dot(v) > 1.0 - 1e-9;
    v = next;
    if (settled) break;
  }
  if (support < 20 || 20 * support < normals.size()) return std::nullopt;
  return v;
}

}  // namespace

std::optional<Eigen::Vector3d> floorNormal(const std::vector<Vector3f>& points, double cell,
                                           const Eigen::Vector3d& nominal, double max_tilt_deg) {
  // Sparse clouds have too few points per cell for a patch: coarser patches then.
  for (int level = 0; level < 4; ++level)
    if (auto v = floorNormalAt(points, cell * (1 << level), nominal, max_tilt_deg)) return v;
  return std::nullopt;
}

std::vector<SearchHit> correlativeSearch(const PointCloud& source, const PointCloud& target,
                                         const CorrelativeSearchParams& params,
                                         const Isometry3d& T_target_source_init) {
  params.validate();
  if (source.empty() || target.empty()) return {};
  // The scored subset of the source: a fixed random choice, so a pose's score does not depend on
  // the order of the points.
  std::vector<std::size_t> idx(source.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  const std::size_t n = params.sample_points > 0
                            ? std::min(idx.size(), static_cast<std::size_t>(params.sample_points))
                            : idx.size();
  std::mt19937_64 rng(params.seed);
  for (std::size_t i = 0; i < n; ++i) {
    std::uniform_int_distribution<std::size_t> pick(i, idx.size() - 1);
    std::swap(idx[i], idx[pick(rng)]);
  }
  idx.resize(n);

  const int reach = static_cast<int>(std::lround(params.translation_range / params.cell));
  // Colours: both clouds must carry them (the grey levels of coloured ICP, colorIntensity).
  const bool coloured =
      params.color_tolerance > 0.0 && source.hasColors() && target.hasColors();
  std::vector<std::uint8_t> target_grey, source_grey;
  if (coloured) {
    auto to8 = [](const Color3u8& c) {
      return static_cast<std::uint8_t>(std::lround(255.0f * colorIntensity(c)));
    };
    for (const auto& c : target.colors) target_grey.push_back(to8(c));
    for (const std::size_t i : idx) source_grey.push_back(to8(source.colors[i]));
  }
  const int tolerance = static_cast<int>(std::lround(255.0 * params.color_tolerance));
  const std::vector<std::uint8_t>* grey = coloured ? &source_grey : nullptr;
  const OccupancyField coarse(target.points, params.cell, reach + 1,
                              coloured ? &target_grey : nullptr);
  // The fine field: half the cell, reaching one coarse cell around each heading's best shift.
  const OccupancyField fine(target.points, 0.5 * params.cell, 2 * (reach + 2),
                            coloured ? &target_grey : nullptr);
  const bool any_rotation = params.axis == "any";
  const int axis_index = params.axis == "x" ? 0 : params.axis == "y" ? 1 : 2;
  Eigen::Vector3d axis = Eigen::Vector3d::Unit(axis_index);
  if (params.axis_from_floor && !any_rotation) {
    // The floor's normal in the target frame, back to the source frame by the guess's rotation.
    const Eigen::Matrix3d R_init = T_target_source_init.linear();
    if (const auto up =
            floorNormal(target.points, params.cell, R_init * axis, params.max_tilt_deg))
      axis = (R_init.transpose() * *up).normalized();
  }
  // Shifts per axis [coarse cells]: `reach` across the axis, less along it when asked.
  std::array<int, 3> span{reach, reach, reach};
  if (params.axial_range >= 0.0 && !any_rotation)
    span[static_cast<std::size_t>(axis_index)] =
        std::min(reach, static_cast<int>(std::lround(params.axial_range / params.cell)));
  // The turns: headings about the axis, or every rotation vector of a cubic grid within the
  // range (a rotation vector's length is its angle, so the grid covers the ball of turns).
  const int steps = static_cast<int>(std::floor(params.heading_range_deg / params.heading_step_deg));
  std::vector<Eigen::Vector3d> turns;  // rotation vectors [deg]
  if (!any_rotation) {
    for (int h = -steps; h <= steps; ++h) turns.push_back(h * params.heading_step_deg * axis);
  } else {
    for (int i = -steps; i <= steps; ++i)
      for (int j = -steps; j <= steps; ++j)
        for (int k = -steps; k <= steps; ++k) {
          const Eigen::Vector3d v = params.heading_step_deg * Eigen::Vector3d(i, j, k);
          if (v.norm() <= params.heading_range_deg + 1e-9) turns.push_back(v);
        }
  }
  // With align_centroids: turns about the source's centroid, translations from where the
  // centroids meet.
  Eigen::Vector3d c_source = Eigen::Vector3d::Zero(), c_target = Eigen::Vector3d::Zero();
  if (params.align_centroids) {
    for (const auto& q : source.points) c_source += q.cast<double>();
    for (const auto& q : target.points) c_target += q.cast<double>();
    c_source /= static_cast<double>(source.size());
    c_target /= static_cast<double>(target.size());
  }
  std::vector<SearchHit> all;
  for (const Eigen::Vector3d& rv : turns) {
    const double deg = rv.norm();
    const Eigen::Vector3d turn_axis = deg > 0.0 ? Eigen::Vector3d(rv / deg) : axis;
    // Signed heading about the axis for the single-axis search (its grid runs through −range).
    const double heading = any_rotation ? deg : rv.dot(axis);
    Isometry3d turn = Isometry3d::Identity();
    turn.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, turn_axis).toRotationMatrix();
    if (params.align_centroids) turn.translation() = c_source - turn.linear() * c_source;
    Isometry3d T0 = T_target_source_init * turn;
    if (params.align_centroids) T0.translation() += c_target - T0 * c_source;
    std::vector<Eigen::Vector3d> pts(n);
    for (std::size_t i = 0; i < n; ++i) pts[i] = T0 * source.points[idx[i]].cast<double>();
    // Coarse: every shift of the grid. A shift by whole cells moves each point's cell by the
    // same offset, so the score is a correlation of the points' cells with the field.
    const auto base = baseCells(coarse, pts, reach);
    struct Shift {
      std::int64_t score;
      std::array<int, 3> cells;
    };
    std::vector<Shift> shifts;
    shifts.reserve(static_cast<std::size_t>(2 * span[0] + 1) * (2 * span[1] + 1) *
                   (2 * span[2] + 1));
    for (int z = -span[2]; z <= span[2]; ++z)
      for (int y = -span[1]; y <= span[1]; ++y)
        for (int x = -span[0]; x <= span[0]; ++x)
          shifts.push_back({scoreShift(coarse, base, {x, y, z}, grey, tolerance), {x, y, z}});
    // The best shifts of this heading, pairwise min_separation_m apart (a slide along a wall
    // can outscore the right place by a few points: both go on to the refinement).
    std::stable_sort(shifts.begin(), shifts.end(),
                     [](const Shift& a, const Shift& b) { return a.score > b.score; });
    std::vector<std::array<int, 3>> kept;
    for (const Shift& sh : shifts) {
      if (static_cast<int>(kept.size()) >= params.shifts_per_heading) break;
      const bool apart = std::all_of(kept.begin(), kept.end(), [&](const auto& k) {
        const Eigen::Vector3d d(sh.cells[0] - k[0], sh.cells[1] - k[1], sh.cells[2] - k[2]);
        return params.cell * d.norm() >= params.min_separation_m;
      });
      if (apart) kept.push_back(sh.cells);
    }
    // Fine: half cells within one coarse cell of each kept shift.
    const auto fbase = baseCells(fine, pts, 2 * reach + 2);
    for (const auto& best_shift : kept) {
      std::int64_t fbest = -1;
      std::array<int, 3> fshift{0, 0, 0};
      for (int z = -2; z <= 2; ++z)
        for (int y = -2; y <= 2; ++y)
          for (int x = -2; x <= 2; ++x) {
            const std::array<int, 3> s3{2 * best_shift[0] + x, 2 * best_shift[1] + y,
                                        2 * best_shift[2] + z};
            const std::int64_t sc = scoreShift(fine, fbase, s3, grey, tolerance);
            if (sc > fbest) {
              fbest = sc;
              fshift = s3;
            }
          }
      SearchHit hit;
      hit.heading_deg = heading;
      hit.axis = any_rotation ? turn_axis : axis;
      hit.T_target_source = T0;
      hit.T_target_source.translation() +=
          fine.cell * Eigen::Vector3d(fshift[0], fshift[1], fshift[2]);
      hit.score = static_cast<double>(fbest) / (2.0 * static_cast<double>(n));
      all.push_back(hit);
    }
  }
  std::stable_sort(all.begin(), all.end(),
                   [](const SearchHit& a, const SearchHit& b) { return a.score > b.score; });
  std::vector<SearchHit> out;
  for (const auto& h : all) {
    if (static_cast<int>(out.size()) >= params.candidates) break;
    const bool apart = std::all_of(out.begin(), out.end(), [&](const SearchHit& o) {
      // The angle between the two rotations (about one axis: the heading difference).
      const double turn_deg =
          Eigen::AngleAxisd(o.T_target_source.linear().transpose() * h.T_target_source.linear())
              .angle() *
          180.0 / M_PI;
      return turn_deg >= params.min_separation_deg - 1e-6 ||
             (o.T_target_source.translation() - h.T_target_source.translation()).norm() >=
                 params.min_separation_m;
    });
    if (apart) out.push_back(h);
  }
  return out;
}

}  // namespace obm::registration
