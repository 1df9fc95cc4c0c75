#include "obm/io/rgbd.hpp"

#include <png.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/redwood_log.hpp"
#include "text_lines.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Intrinsics

Eigen::Matrix3d PinholeIntrinsics::K() const {
  Eigen::Matrix3d K;
  K << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return K;
}

PinholeIntrinsics readOpen3dIntrinsics(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError("cannot open '" + path + "' for reading");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(path, 0, std::string("not valid JSON: ") + e.what());
  }
  const auto need = [&](const char* key) -> const nlohmann::json& {
    if (!j.is_object() || !j.contains(key))
      throw FormatError(path, 0, std::string("missing key '") + key + "'");
    return j.at(key);
  };
  PinholeIntrinsics K;
  const auto& w = need("width");
  const auto& h = need("height");
  if (!w.is_number_integer() || !h.is_number_integer() || w.get<long long>() <= 0 ||
      h.get<long long>() <= 0)
    throw FormatError(path, 0, "'width' and 'height' must be positive integers");
  K.width = w.get<int>();
  K.height = h.get<int>();
  const auto& m = need("intrinsic_matrix");
  if (!m.is_array() || m.size() != 9)
    throw FormatError(path, 0, "'intrinsic_matrix' must be an array of 9 numbers");
  double v[9];
  for (std::size_t k = 0; k < 9; ++k) {
    if (!m[k].is_number()) throw FormatError(path, 0, "'intrinsic_matrix' must hold numbers");
    v[k] = m[k].get<double>();
  }
  // Open3D stores K column by column: [fx, 0, 0, 0, fy, 0, cx, cy, 1].
  K.fx = v[0];
  K.fy = v[4];
  K.cx = v[6];
  K.cy = v[7];
  if (!(K.fx > 0.0) || !(K.fy > 0.0) || !std::isfinite(K.cx) || !std::isfinite(K.cy))
    throw FormatError(path, 0, "'intrinsic_matrix' has a non-positive focal length");
  return K;
}

void writeOpen3dIntrinsics(const std::string& path, const PinholeIntrinsics& K) {
  nlohmann::json j;
  j["width"] = K.width;
  j["height"] = K.height;
  j["intrinsic_matrix"] = {K.fx, 0.0, 0.0, 0.0, K.fy, 0.0, K.cx, K.cy, 1.0};
  writeTextAtomically(path, j.dump(1, '\t') + "\n");
}

// ---------------------------------------------------------------------------------------------
// PNG through libpng. libpng reports errors by longjmp; the functions that call setjmp hold no
// C++ object with a destructor, so nothing is skipped, and errors are re-thrown as exceptions
// once control is back in ordinary C++ code.

namespace {

struct PngErrorSink {
  char message[256] = {0};
};

void pngError(png_structp png, png_const_charp msg) {
  auto* sink = static_cast<PngErrorSink*>(png_get_error_ptr(png));
  std::snprintf(sink->message, sizeof(sink->message), "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

void pngWarning(png_structp, png_const_charp msg) {
  OBM_LOG_DEBUG("io.png", "libpng: " << (msg ? msg : ""));
}

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

enum class PngKind { Gray16, Rgb8 };

/// Decoded pixels and header, filled by pngDecode().
struct PngPixels {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  std::vector<std::uint8_t> bytes;
  std::vector<png_bytep> rows;
  std::string format_error;  // set when the image is a valid PNG of the wrong kind
};

constexpr bool hostIsLittleEndian() {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  return false;
#else
  return true;
#endif
}

/// 0 = decoded, 1 = libpng error (message in the sink), 2 = wrong kind (out->format_error).
int pngDecode(png_structp png, png_infop info, std::FILE* fp, PngKind kind, PngPixels* out) {
  if (setjmp(png_jmpbuf(png))) return 1;
  png_init_io(png, fp);
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  out->width = png_get_image_width(png, info);
  out->height = png_get_image_height(png, info);
  out->bit_depth = png_get_bit_depth(png, info);
  out->color_type = png_get_color_type(png, info);
  if (kind == PngKind::Gray16) {
    if (out->color_type != PNG_COLOR_TYPE_GRAY || out->bit_depth != 16) {
      out->format_error = "expected a 16-bit single-channel (greyscale) PNG, got " +
                          std::to_string(out->bit_depth) + "-bit colour type " +
                          std::to_string(out->color_type);
      return 2;
    }
    if (hostIsLittleEndian()) png_set_swap(png);  // PNG stores 16-bit samples big-endian
  } else {
    if (out->color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (out->color_type == PNG_COLOR_TYPE_GRAY && out->bit_depth < 8)
      png_set_expand_gray_1_2_4_to_8(png);
    if (out->bit_depth == 16) png_set_strip_16(png);
    if (out->color_type == PNG_COLOR_TYPE_GRAY || out->color_type == PNG_COLOR_TYPE_GRAY_ALPHA)
      png_set_gray_to_rgb(png);
    if (out->color_type & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const std::size_t rowbytes = png_get_rowbytes(png, info);
  const std::size_t expected = (kind == PngKind::Gray16 ? 2u : 3u) * out->width;
  if (rowbytes != expected) {
    out->format_error = "unexpected row size " + std::to_string(rowbytes) + " bytes after decoding";
    return 2;
  }
  out->bytes.resize(rowbytes * out->height);
  out->rows.resize(out->height);
  for (png_uint_32 r = 0; r < out->height; ++r) out->rows[r] = out->bytes.data() + r * rowbytes;
  png_read_image(png, out->rows.data());
  png_read_end(png, nullptr);
  return 0;
}

PngPixels readPng(const std::string& path, PngKind kind) {
  FilePtr fp(std::fopen(path.c_str(), "rb"));
  if (!fp) throw IoError("cannot open '" + path + "' for reading: " + std::strerror(errno));
  png_byte sig[8];
  if (std::fread(sig, 1, 8, fp.get()) != 8 || png_sig_cmp(sig, 0, 8) != 0)
    throw FormatError(path, 0, "not a PNG file");
  PngErrorSink sink;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &sink, pngError, pngWarning);
  if (!png) throw IoError("cannot read '" + path + "': libpng initialisation failed");
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    throw IoError("cannot read '" + path + "': libpng initialisation failed");
  }
  PngPixels px;
  int rc = 0;
  try {
    rc = pngDecode(png, info, fp.get(), kind, &px);
  } catch (...) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw;
  }
  png_destroy_read_struct(&png, &info, nullptr);
  if (rc == 1) throw FormatError(path, 0, std::string("corrupt PNG: ") + sink.message);
  if (rc == 2) throw FormatError(path, 0, px.format_error);
  return px;
}

/// 0 = written, 1 = libpng error (message in the sink).
int pngEncode(png_structp png, png_infop info, std::FILE* fp, PngKind kind, int width, int height,
              png_bytep* rows) {
  if (setjmp(png_jmpbuf(png))) return 1;
  png_init_io(png, fp);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               kind == PngKind::Gray16 ? 16 : 8,
               kind == PngKind::Gray16 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (kind == PngKind::Gray16 && hostIsLittleEndian()) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return 0;
}

void writePng(const std::string& path, PngKind kind, int width, int height,
              const std::uint8_t* data) {
  const std::string tmp = temporaryPathFor(path);
  FilePtr fp(std::fopen(tmp.c_str(), "wb"));
  if (!fp) throw IoError("cannot write '" + path + "': " + std::strerror(errno));
  const std::size_t rowbytes = static_cast<std::size_t>(width) * (kind == PngKind::Gray16 ? 2 : 3);
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int r = 0; r < height; ++r)
    rows[static_cast<std::size_t>(r)] = const_cast<png_bytep>(data + r * rowbytes);
  PngErrorSink sink;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, pngError, pngWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  int rc = 1;
  if (png && info) rc = pngEncode(png, info, fp.get(), kind, width, height, rows.data());
  png_destroy_write_struct(&png, &info);
  const bool flushed = std::fflush(fp.get()) == 0 && !std::ferror(fp.get());
  const bool closed = std::fclose(fp.release()) == 0;
  if (rc != 0 || !flushed || !closed) {
    std::remove(tmp.c_str());
    throw IoError("cannot write '" + path + "': " +
                  (rc != 0 ? std::string(sink.message[0] ? sink.message : "libpng failure")
                           : std::string("write failed (disk full?)")));
  }
  commitTemporaryFile(tmp, path);
}

void checkImageSize(int width, int height, std::size_t n, std::size_t per_pixel,
                    const std::string& path) {
  OBM_ASSERT(
      width > 0 && height > 0 &&
          n == static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * per_pixel,
      "image for '" + path + "' has " + std::to_string(n) + " values for " + std::to_string(width) +
          "x" + std::to_string(height) + " pixels");
}

}  // namespace

DepthImage readDepthPng(const std::string& path) {
  PngPixels px = readPng(path, PngKind::Gray16);
  DepthImage img;
  img.width = static_cast<int>(px.width);
  img.height = static_cast<int>(px.height);
  img.data.resize(static_cast<std::size_t>(px.width) * px.height);
  std::memcpy(img.data.data(), px.bytes.data(), img.data.size() * 2);
  return img;
}

void writeDepthPng(const std::string& path, const DepthImage& image) {
  checkImageSize(image.width, image.height, image.data.size(), 1, path);
  writePng(path, PngKind::Gray16, image.width, image.height,
           reinterpret_cast<const std::uint8_t*>(image.data.data()));
}

ColorImage readColorPng(const std::string& path) {
  PngPixels px = readPng(path, PngKind::Rgb8);
  ColorImage img;
  img.width = static_cast<int>(px.width);
  img.height = static_cast<int>(px.height);
  img.rgb = std::move(px.bytes);
  return img;
}

void writeColorPng(const std::string& path, const ColorImage& image) {
  checkImageSize(image.width, image.height, image.rgb.size(), 3, path);
  writePng(path, PngKind::Rgb8, image.width, image.height, image.rgb.data());
}

// ---------------------------------------------------------------------------------------------
// Back-projection

std::size_t removeDepthEdges(DepthImage& depth, double max_relative_jump) {
  if (!(max_relative_jump > 0.0) || depth.data.empty()) return 0;
  const int W = depth.width, H = depth.height;
  // Raw units cancel in the relative test; 0 and 65535 are "no measurement".
  auto valid = [](std::uint16_t v) { return v != 0 && v != 0xFFFF; };
  std::vector<std::uint8_t> edge(depth.data.size(), 0);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const std::uint16_t z = depth.at(u, v);
      if (!valid(z)) continue;
      const double limit = max_relative_jump * z;
      const int nu[4] = {u - 1, u + 1, u, u}, nv[4] = {v, v, v - 1, v + 1};
      for (int k = 0; k < 4; ++k) {
        if (nu[k] < 0 || nu[k] >= W || nv[k] < 0 || nv[k] >= H) continue;
        const std::uint16_t zn = depth.at(nu[k], nv[k]);
        if (valid(zn) && std::abs(double(zn) - double(z)) > limit) {
          edge[static_cast<std::size_t>(v) * W + u] = 1;
          break;
        }
      }
    }
  std::size_t removed = 0;
  for (std::size_t k = 0; k < edge.size(); ++k)
    if (edge[k]) {
      depth.data[k] = 0;
      ++removed;
    }
  return removed;
}

PointCloud depthToCloud(const DepthImage& depth, const PinholeIntrinsics& K, double depth_scale,
                        double min_depth, double max_depth, int stride, const ColorImage* color) {
  OBM_ASSERT(depth.width == K.width && depth.height == K.height,
             "depth image is " + std::to_string(depth.width) + "x" + std::to_string(depth.height) +
                 " but the intrinsics are for " + std::to_string(K.width) + "x" +
                 std::to_string(K.height));
  OBM_ASSERT(depth.data.size() == static_cast<std::size_t>(depth.width) * depth.height,
             "depth image data size does not match its width and height");
  OBM_ASSERT(depth_scale > 0.0, "depth_scale must be positive");
  OBM_ASSERT(stride >= 1, "stride must be >= 1");
  OBM_ASSERT(K.fx != 0.0 && K.fy != 0.0, "focal lengths must be non-zero");
  if (color)
    OBM_ASSERT(color->width == depth.width && color->height == depth.height &&
                   color->rgb.size() == depth.data.size() * 3,
               "colour image size differs from the depth image");
  PointCloud pc;
  pc.frame_id = "camera";
  const int nu = (depth.width + stride - 1) / stride, nv = (depth.height + stride - 1) / stride;
  pc.reserve(static_cast<std::size_t>(nu) * nv);
  if (color) pc.colors.reserve(static_cast<std::size_t>(nu) * nv);
  const double inv_fx = 1.0 / K.fx, inv_fy = 1.0 / K.fy, inv_scale = 1.0 / depth_scale;
  for (int v = 0; v < depth.height; v += stride) {
    for (int u = 0; u < depth.width; u += stride) {
      const std::uint16_t raw = depth.at(u, v);
      if (raw == 0 || raw == 65535) continue;  // no measurement
      const double z = raw * inv_scale;
      if (z < min_depth || z > max_depth) continue;
      pc.points.emplace_back(static_cast<float>((u - K.cx) * z * inv_fx),
                             static_cast<float>((v - K.cy) * z * inv_fy), static_cast<float>(z));
      if (color) pc.colors.push_back(color->at(u, v));
    }
  }
  return pc;
}

// ---------------------------------------------------------------------------------------------
// TUM list files

std::vector<StampedFile> readTumFileList(const std::string& path) {
  txt::LineReader reader(path);
  std::vector<StampedFile> out;
  std::string line;
  while (reader.next(line)) {
    const auto body = txt::trimLeft(line);
    if (body.empty() || body.front() == '#') continue;
    const auto tok = txt::tokenize(body);
    if (tok.size() != 2)
      throw FormatError(
          path, reader.lineNumber(),
          "expected 'timestamp filename', got " + std::to_string(tok.size()) + " fields");
    StampedFile f;
    f.t = txt::parseDouble(tok[0], path, reader.lineNumber(), "the time stamp");
    if (!std::isfinite(f.t)) throw FormatError(path, reader.lineNumber(), "non-finite time stamp");
    f.path = std::string(tok[1]);
    out.push_back(std::move(f));
  }
  return out;
}

void writeTumFileList(const std::string& path, const std::vector<StampedFile>& entries,
                      const std::string& header) {
  writeFileAtomically(path, [&](std::ostream& os) {
    if (!header.empty()) os << "# " << header << '\n';
    for (const auto& e : entries) os << txt::formatExact(e.t) << ' ' << e.path << '\n';
  });
}

// ---------------------------------------------------------------------------------------------
// Sequences

namespace {

std::string joinPath(const std::string& dir, const std::string& rel) {
  return (fs::path(dir) / rel).string();
}

/// Fills colour and pose of frames (already holding depth time + path) by association.
void associateColor(std::vector<RgbdFrame>& frames, const std::vector<StampedFile>& colors,
                    const std::string& dir, const RgbdSequenceOptions& opt) {
  std::vector<double> td, tc;
  for (const auto& f : frames) td.push_back(f.timestamp);
  for (const auto& c : colors) tc.push_back(c.t);
  for (const auto& m : associateTimestamps(td, tc, opt.max_time_difference)) {
    frames[m.first].color_path = joinPath(dir, colors[m.second].path);
    frames[m.first].color_timestamp = colors[m.second].t;
  }
  if (opt.require_color)
    frames.erase(std::remove_if(frames.begin(), frames.end(),
                                [](const RgbdFrame& f) { return f.color_path.empty(); }),
                 frames.end());
}

void associateGroundTruth(std::vector<RgbdFrame>& frames, const Trajectory& gt,
                          const RgbdSequenceOptions& opt) {
  std::vector<double> td;
  for (const auto& f : frames) td.push_back(f.timestamp);
  for (const auto& m : associateTimestamps(td, timestampsOf(gt), opt.max_time_difference)) {
    frames[m.first].has_pose = true;
    frames[m.first].T_world_camera = gt[m.second].T;
  }
}

void sortByTime(std::vector<RgbdFrame>& frames) {
  std::stable_sort(frames.begin(), frames.end(), [](const RgbdFrame& a, const RgbdFrame& b) {
    return a.timestamp < b.timestamp;
  });
}

/// Frames from a TUM depth list (+ optional colour list and ground truth).
std::vector<RgbdFrame> tumFrames(const std::string& dir, const std::string& depth_list,
                                 const std::string& rgb_list, const std::string& gt_path,
                                 const RgbdSequenceOptions& opt) {
  std::vector<RgbdFrame> frames;
  for (const auto& d : readTumFileList(depth_list)) {
    RgbdFrame f;
    f.timestamp = d.t;
    f.depth_path = joinPath(dir, d.path);
    frames.push_back(std::move(f));
  }
  sortByTime(frames);
  if (!rgb_list.empty()) {
    associateColor(frames, readTumFileList(rgb_list), dir, opt);
  } else if (opt.require_color) {
    throw IoError("RGB-D folder '" + dir + "' has no colour list (rgb.txt)");
  }
  if (!gt_path.empty()) associateGroundTruth(frames, readTumTrajectory(gt_path), opt);
  return frames;
}

std::string existingOr(const std::string& path, const std::string& fallback = "") {
  return fs::is_regular_file(path) ? path : fallback;
}

void requireFolder(const std::string& dir, const char* what) {
  if (!fs::is_directory(dir))
    throw IoError(std::string(what) + " folder '" + dir + "' does not exist");
}

/// Reads a 7-Scenes `frame-XXXXXX.pose.txt`: 4 lines of 4 numbers, camera-to-world.
Isometry3d readPose4x4(const std::string& path) {
  txt::LineReader reader(path);
  Eigen::Matrix4d M;
  int row = 0;
  std::string line;
  while (reader.next(line)) {
    if (txt::isBlank(line)) continue;
    if (row == 4) throw FormatError(path, reader.lineNumber(), "more than 4 matrix rows");
    const auto tok = txt::tokenize(line);
    if (tok.size() != 4)
      throw FormatError(path, reader.lineNumber(),
                        "expected 4 numbers per row, got " + std::to_string(tok.size()));
    for (int c = 0; c < 4; ++c) {
      M(row, c) = txt::parseDouble(tok[static_cast<std::size_t>(c)], path, reader.lineNumber(),
                                   "a matrix entry");
      if (!std::isfinite(M(row, c)))
        throw FormatError(path, reader.lineNumber(), "non-finite matrix entry");
    }
    ++row;
  }
  if (row != 4)
    throw FormatError(path, reader.lineNumber(),
                      "expected a 4x4 matrix, got " + std::to_string(row) + " rows");
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6)
    throw FormatError(path, 4, "last matrix row must be '0 0 0 1'");
  Isometry3d T = Isometry3d::Identity();
  T.linear() = M.topLeftCorner<3, 3>();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string lowerExt(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

}  // namespace

void RgbdSequence::setDepthScale(double depth_scale) {
  OBM_ASSERT(depth_scale > 0.0 && std::isfinite(depth_scale), "depth_scale must be positive");
  depth_scale_ = depth_scale;
}

RgbdSequence RgbdSequence::openTum(const std::string& dir, const RgbdSequenceOptions& opt) {
  requireFolder(dir, "TUM RGB-D");
  const std::string depth_list = joinPath(dir, "depth.txt");
  if (!fs::is_regular_file(depth_list))
    throw IoError("TUM RGB-D folder '" + dir + "' has no depth.txt");
  RgbdSequence s;
  s.dir_ = dir;
  s.depth_scale_ = 5000.0;  // TUM: "a pixel value of 5000 in the depth image corresponds to 1 m"
  s.intrinsics_ = PinholeIntrinsics{};
  const std::string gt = opt.groundtruth_path.empty() ? existingOr(joinPath(dir, "groundtruth.txt"))
                                                      : opt.groundtruth_path;
  s.frames_ = tumFrames(dir, depth_list, existingOr(joinPath(dir, "rgb.txt")), gt, opt);
  return s;
}

RgbdSequence RgbdSequence::openIclNuim(const std::string& dir, const RgbdSequenceOptions& opt) {
  requireFolder(dir, "ICL-NUIM");
  RgbdSequence s;
  s.dir_ = dir;
  s.depth_scale_ = 5000.0;
  s.intrinsics_ = PinholeIntrinsics{640, 480, 481.20, 480.00, 319.5, 239.5};
  std::string gt = opt.groundtruth_path;
  if (gt.empty()) gt = existingOr(joinPath(dir, "groundtruth.txt"));
  if (gt.empty()) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(dir))
      if (endsWith(e.path().filename().string(), ".gt.freiburg"))
        found.push_back(e.path().string());
    std::sort(found.begin(), found.end());
    if (!found.empty()) gt = found.front();
  }
  const std::string depth_list = joinPath(dir, "depth.txt");
  if (fs::is_regular_file(depth_list)) {
    s.frames_ = tumFrames(dir, depth_list, existingOr(joinPath(dir, "rgb.txt")), gt, opt);
    return s;
  }
  const std::string assoc = joinPath(dir, "associations.txt");
  if (!fs::is_regular_file(assoc))
    throw IoError("ICL-NUIM folder '" + dir + "' has neither depth.txt nor associations.txt");
  txt::LineReader reader(assoc);
  std::string line;
  while (reader.next(line)) {
    const auto body = txt::trimLeft(line);
    if (body.empty() || body.front() == '#') continue;
    const auto tok = txt::tokenize(body);
    if (tok.size() != 4)
      throw FormatError(
          assoc, reader.lineNumber(),
          "expected 'time path time path', got " + std::to_string(tok.size()) + " fields");
    // The order of the two images is not fixed (associate.py writes its first argument first):
    // the depth image is the one whose path names a depth folder.
    const bool depth_first = std::string(tok[1]).find("depth") != std::string::npos;
    const bool depth_second = std::string(tok[3]).find("depth") != std::string::npos;
    if (depth_first == depth_second)
      throw FormatError(assoc, reader.lineNumber(),
                        "cannot tell which image is the depth image (exactly one path must "
                        "contain 'depth')");
    const std::size_t d = depth_first ? 0 : 2, c = depth_first ? 2 : 0;
    RgbdFrame f;
    f.timestamp = txt::parseDouble(tok[d], assoc, reader.lineNumber(), "the depth time stamp");
    f.depth_path = joinPath(dir, std::string(tok[d + 1]));
    f.color_timestamp =
        txt::parseDouble(tok[c], assoc, reader.lineNumber(), "the colour time stamp");
    f.color_path = joinPath(dir, std::string(tok[c + 1]));
    if (!std::isfinite(f.timestamp) || !std::isfinite(f.color_timestamp))
      throw FormatError(assoc, reader.lineNumber(), "non-finite time stamp");
    s.frames_.push_back(std::move(f));
  }
  sortByTime(s.frames_);
  if (!gt.empty()) associateGroundTruth(s.frames_, readTumTrajectory(gt), opt);
  return s;
}

RgbdSequence RgbdSequence::open7Scenes(const std::string& dir, const RgbdSequenceOptions& opt) {
  requireFolder(dir, "7-Scenes sequence");
  RgbdSequence s;
  s.dir_ = dir;
  s.depth_scale_ = 1000.0;  // millimetres
  s.intrinsics_ = PinholeIntrinsics{640, 480, 585.0, 585.0, 320.0, 240.0};
  std::vector<std::string> depth_files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("frame-", 0) == 0 && endsWith(name, ".depth.png"))
      depth_files.push_back(e.path().string());
  }
  std::sort(depth_files.begin(), depth_files.end());
  if (depth_files.empty())
    throw IoError("7-Scenes folder '" + dir + "' has no frame-XXXXXX.depth.png files");
  for (const auto& dpath : depth_files) {
    const std::string stem = dpath.substr(0, dpath.size() - std::string(".depth.png").size());
    const std::string number = fs::path(stem).filename().string().substr(6);  // after "frame-"
    RgbdFrame f;
    f.timestamp =
        static_cast<double>(txt::parseInt(number, dpath, 0, "the frame number in the file name")) /
        30.0;
    f.depth_path = dpath;
    f.color_path = existingOr(stem + ".color.png");
    f.color_timestamp = f.timestamp;
    const std::string pose = stem + ".pose.txt";
    if (opt.groundtruth_path.empty() && fs::is_regular_file(pose)) {
      f.T_world_camera = readPose4x4(pose);
      f.has_pose = true;
    }
    if (opt.require_color && f.color_path.empty()) continue;
    s.frames_.push_back(std::move(f));
  }
  if (!opt.groundtruth_path.empty())
    associateGroundTruth(s.frames_, readTumTrajectory(opt.groundtruth_path), opt);
  return s;
}

RgbdLayout parseRgbdLayout(const std::string& name) {
  const std::string n = detail::toLower(name);
  if (n == "tum") return RgbdLayout::Tum;
  if (n == "iclnuim" || n == "icl-nuim") return RgbdLayout::IclNuim;
  if (n == "7scenes" || n == "7-scenes") return RgbdLayout::SevenScenes;
  if (n == "redwood") return RgbdLayout::Redwood;
  throw ConfigError("unknown RGB-D layout '" + name +
                    "' (expected tum, iclnuim, 7scenes or redwood)");
}

RgbdSequence RgbdSequence::open(const std::string& dir, RgbdLayout layout,
                                const RgbdSequenceOptions& options) {
  switch (layout) {
    case RgbdLayout::Tum:
    case RgbdLayout::IclNuim: {
      RgbdSequence seq =
          layout == RgbdLayout::Tum ? openTum(dir, options) : openIclNuim(dir, options);
      // obm-sim (and Open3D) write the intrinsics next to the images for other cameras.
      for (const char* name : {"camera_intrinsic.json", "camera_primesense.json"}) {
        const std::string f = joinPath(seq.directory(), name);
        if (!fs::is_regular_file(f)) continue;
        seq.setIntrinsics(readOpen3dIntrinsics(f));
        OBM_LOG_INFO("io.rgbd", "intrinsics from " << f);
        break;
      }
      return seq;
    }
    case RgbdLayout::SevenScenes:
      return open7Scenes(dir, options);
    case RgbdLayout::Redwood:
      return openRedwood(dir, options);
  }
  throw ContractError("RgbdSequence::open: unknown layout");
}

RgbdSequence RgbdSequence::open(const std::string& dir, const RgbdSequenceOptions& options) {
  switch (detectDatasetKind(dir)) {
    case DatasetKind::TumRgbd:
      return open(dir, RgbdLayout::Tum, options);
    case DatasetKind::IclNuim:
      return open(dir, RgbdLayout::IclNuim, options);
    case DatasetKind::SevenScenes:
      return open(dir, RgbdLayout::SevenScenes, options);
    case DatasetKind::Redwood:
      return open(dir, RgbdLayout::Redwood, options);
    case DatasetKind::Kitti:
    case DatasetKind::Rawlog:
      throw IoError("'" + dir + "' is a " + toString(detectDatasetKind(dir)) +
                    " dataset, not an RGB-D folder (TUM RGB-D, ICL-NUIM, 7-Scenes or Redwood)");
  }
  throw ContractError("RgbdSequence::open: unknown dataset kind");
}

RgbdSequence RgbdSequence::openRedwood(const std::string& dir, const RgbdSequenceOptions& opt) {
  requireFolder(dir, "RGB-D");
  const std::string depth_dir = joinPath(dir, "depth");
  requireFolder(depth_dir, "depth image");
  RgbdSequence s;
  s.dir_ = dir;
  s.depth_scale_ = 1000.0;
  for (const char* name : {"camera_primesense.json", "camera_intrinsic.json"}) {
    const std::string p = joinPath(dir, name);
    if (fs::is_regular_file(p)) {
      s.intrinsics_ = readOpen3dIntrinsics(p);
      break;
    }
  }
  std::vector<fs::path> depth_files;
  for (const auto& e : fs::directory_iterator(depth_dir))
    if (lowerExt(e.path()) == ".png") depth_files.push_back(e.path());
  std::sort(depth_files.begin(), depth_files.end());
  if (depth_files.empty()) throw IoError("folder '" + depth_dir + "' has no PNG depth images");
  // Colour images are paired by file stem (depth/00042.png ↔ color/00042.jpg).
  std::vector<fs::path> color_files;
  const std::string color_dir = joinPath(dir, "color");
  if (fs::is_directory(color_dir))
    for (const auto& e : fs::directory_iterator(color_dir)) color_files.push_back(e.path());
  std::sort(color_files.begin(), color_files.end());
  for (std::size_t k = 0; k < depth_files.size(); ++k) {
    RgbdFrame f;
    f.timestamp = static_cast<double>(k) / 30.0;
    f.depth_path = depth_files[k].string();
    for (const auto& c : color_files)
      if (c.stem() == depth_files[k].stem()) {
        f.color_path = c.string();
        f.color_timestamp = f.timestamp;
        break;
      }
    if (opt.require_color && f.color_path.empty()) continue;
    s.frames_.push_back(std::move(f));
  }
  const std::string traj = opt.groundtruth_path.empty()
                               ? existingOr(joinPath(dir, "trajectory.log"))
                               : opt.groundtruth_path;
  if (!traj.empty()) {
    const auto poses = readRedwoodTrajectory(traj);
    if (poses.size() != depth_files.size())
      throw FormatError(traj, 0,
                        std::to_string(poses.size()) + " poses but " +
                            std::to_string(depth_files.size()) + " depth images in '" + depth_dir +
                            "'");
    if (s.frames_.size() != depth_files.size())
      throw IoError("RGB-D folder '" + dir +
                    "': require_color dropped frames, poses can no longer be paired by index");
    for (std::size_t k = 0; k < poses.size(); ++k) {
      s.frames_[k].T_world_camera = poses[k];
      s.frames_[k].has_pose = true;
    }
  }
  return s;
}

const RgbdFrame& RgbdSequence::frame(std::size_t i) const {
  OBM_ASSERT(i < frames_.size(), "frame index " + std::to_string(i) + " out of range (" +
                                     std::to_string(frames_.size()) + " frames in '" + dir_ + "')");
  return frames_[i];
}

DepthImage RgbdSequence::depth(std::size_t i) const {
  return readDepthPng(frame(i).depth_path);
}

PointCloud RgbdSequence::cloud(std::size_t i, double min_depth, double max_depth, int stride,
                               bool with_color, double edge_jump) const {
  const RgbdFrame& f = frame(i);
  DepthImage d = readDepthPng(f.depth_path);
  if (edge_jump > 0.0) removeDepthEdges(d, edge_jump);
  ColorImage c;
  if (with_color) {
    if (f.color_path.empty())
      throw IoError("frame " + std::to_string(i) + " of '" + dir_ + "' has no colour image");
    c = readColorImage(f.color_path);
  }
  PointCloud pc = depthToCloud(d, intrinsics_, depth_scale_, min_depth, max_depth, stride,
                               with_color ? &c : nullptr);
  pc.timestamp = f.timestamp;
  return pc;
}

Trajectory RgbdSequence::groundTruth() const {
  Trajectory out;
  for (const auto& f : frames_)
    if (f.has_pose) out.push_back({f.timestamp, f.T_world_camera});
  return out;
}

}  // namespace obm::io
