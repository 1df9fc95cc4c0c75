#pragma once
/// \file rgbd.hpp
/// Depth / RGB-D images and sequences: 16-bit depth PNG and 8-bit colour PNG read / write (libpng),
/// pinhole intrinsics (Open3D's `PinholeCameraIntrinsic` JSON), back-projection of a depth image
/// into a point cloud, and the folder layouts of TUM RGB-D, ICL-NUIM (TUM-compatible release),
/// Microsoft 7-Scenes and Redwood / Open3D RGB-D sequences.
///
/// Clouds are in the camera optical frame (frame_id "camera"): x right, y down, z forward along
/// the optical axis, [m]. Pixel (u, v) is column u, row v of the image, its centre at integer
/// coordinates, so the principal point of a 640×480 image centred on the sensor is (319.5, 239.5).
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/trajectory.hpp"

namespace obm::io {

/// Pinhole camera without distortion. Defaults: the PrimeSense / Kinect values of Open3D's
/// `camera_primesense.json` and of the TUM RGB-D "ROS default" calibration.
struct PinholeIntrinsics {
  int width = 640;    ///< [px]
  int height = 480;   ///< [px]
  double fx = 525.0;  ///< [px] focal length along x
  double fy = 525.0;  ///< [px] focal length along y
  double cx = 319.5;  ///< [px] principal point, column
  double cy = 239.5;  ///< [px] principal point, row

  /// The 3×3 calibration matrix K.
  Eigen::Matrix3d K() const;
};

/// Reads Open3D's intrinsics JSON (`{"width", "height", "intrinsic_matrix": [9 numbers, column-
/// major K]}`, e.g. `camera_primesense.json`). Throws IoError / FormatError naming the file and the
/// missing or malformed key.
PinholeIntrinsics readOpen3dIntrinsics(const std::string& path);

/// Writes the same JSON layout, atomically.
void writeOpen3dIntrinsics(const std::string& path, const PinholeIntrinsics& intrinsics);

/// A 16-bit single-channel depth image, row-major; raw sensor units (see depthToCloud()).
struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> data;  ///< width·height values, row v at [v·width, (v+1)·width)

  std::uint16_t at(int u, int v) const { return data[static_cast<std::size_t>(v) * width + u]; }
  std::uint16_t& at(int u, int v) { return data[static_cast<std::size_t>(v) * width + u]; }
  bool empty() const noexcept { return data.empty(); }
};

/// An 8-bit RGB image, row-major, 3 bytes per pixel.
struct ColorImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< width·height·3 bytes

  Color3u8 at(int u, int v) const {
    const std::size_t k = 3 * (static_cast<std::size_t>(v) * width + u);
    return Color3u8(rgb[k], rgb[k + 1], rgb[k + 2]);
  }
  bool empty() const noexcept { return rgb.empty(); }
};

/// Reads a 16-bit greyscale PNG. Throws IoError when the file cannot be read and FormatError
/// naming the file when it is not a PNG or not 16-bit single-channel.
DepthImage readDepthPng(const std::string& path);

/// Writes a 16-bit greyscale PNG atomically. ContractError for inconsistent sizes, IoError on
/// failure.
void writeDepthPng(const std::string& path, const DepthImage& image);

/// Reads a PNG as 8-bit RGB (palette and grey are expanded, alpha dropped, 16-bit reduced).
/// Throws IoError / FormatError naming the file.
ColorImage readColorPng(const std::string& path);

/// Reads a baseline or progressive JPEG as 8-bit RGB (grey converted; CMYK refused). Throws
/// IoError when the file cannot be opened and FormatError naming the file when it is not a JPEG,
/// is corrupt, ends before its image does (libjpeg would pad the rest with grey) or is larger
/// than 8192 x 8192 pixels.
ColorImage readColorJpeg(const std::string& path);

/// readColorPng or readColorJpeg by the file's extension (.png, .jpg, .jpeg, any case); IoError
/// for other extensions.
ColorImage readColorImage(const std::string& path);

/// Writes an 8-bit RGB PNG atomically.
void writeColorPng(const std::string& path, const ColorImage& image);

/// Back-projects a depth image into the camera optical frame:
/// z = raw / depth_scale, x = (u − cx)·z / fx, y = (v − cy)·z / fy.
/// Raw values 0 and 65535 mean "no measurement" (TUM, 7-Scenes) and are skipped, as are depths
/// outside [min_depth, max_depth]. Every `stride`-th row and column is used (stride ≥ 1). When
/// `color` is given (same size as the depth image, registered to it) the points carry its colours.
/// The cloud has frame_id "camera" and timestamp 0. Throws ContractError when the image size does
/// not match the intrinsics or an argument is out of range.
/// \param depth_scale raw units per metre: 5000 for TUM and ICL-NUIM, 1000 for 7-Scenes / Redwood
/// \param min_depth [m] nearer measurements are dropped
/// \param max_depth [m] farther measurements are dropped
PointCloud depthToCloud(const DepthImage& depth, const PinholeIntrinsics& intrinsics,
                        double depth_scale, double min_depth = 0.0,
                        double max_depth = std::numeric_limits<double>::infinity(), int stride = 1,
                        const ColorImage* color = nullptr);

/// Removes the pixels on depth discontinuities (in place; returns how many): a valid pixel whose
/// depth differs from a valid 4-neighbour's by more than `max_relative_jump`·z. At an occluding
/// edge a structured-light sensor returns mixed and flying pixels between the two surfaces, whose
/// points belong to neither; the edge pixels of both sides go. `max_relative_jump` <= 0: nothing.
std::size_t removeDepthEdges(DepthImage& depth, double max_relative_jump);

/// One depth frame of a sequence.
struct RgbdFrame {
  double timestamp = 0.0;        ///< [s] time of the depth image
  std::string depth_path;        ///< the depth PNG
  std::string color_path;        ///< the colour image associated with it ("" when none)
  double color_timestamp = 0.0;  ///< [s] time of the colour image
  bool has_pose = false;         ///< whether ground truth was associated with this frame
  Isometry3d T_world_camera = Isometry3d::Identity();  ///< ground truth, camera-to-world
};

/// The RGB-D folder layouts (RgbdSequence::open with a layout, rgbdToRawlog).
enum class RgbdLayout { Tum, IclNuim, SevenScenes, Redwood };

/// Parses "tum", "iclnuim" (or "icl-nuim"), "7scenes" (or "7-scenes"), "redwood"; throws
/// ConfigError naming the accepted values otherwise.
RgbdLayout parseRgbdLayout(const std::string& name);

/// Options of the sequence readers.
struct RgbdSequenceOptions {
  /// [s] association window between depth, colour and ground-truth time stamps (strict bound, as
  /// in the TUM benchmark's associate.py whose default is 0.02 s).
  double max_time_difference = 0.02;
  /// When true, depth frames without a colour image within the window are dropped.
  bool require_color = false;
  /// Ground-truth file to use instead of the layout's own ("" = the layout's).
  std::string groundtruth_path;
};

/// A depth (+ colour) image sequence with intrinsics and optional ground truth. Open it through
/// one of the layout-specific factories; frames are in time order.
class RgbdSequence {
 public:
  /// TUM RGB-D benchmark folder: `depth.txt` and `rgb.txt` (`timestamp path` per line, `#`
  /// comments), `groundtruth.txt` (TUM trajectory, optional). Depth frames are associated with
  /// colour and ground truth by nearest time stamp (associate.py semantics). Depth scale 5000,
  /// intrinsics the ROS default (525, 525, 319.5, 239.5) the TUM page recommends for the
  /// registered depth images. Ground truth is the pose of the colour camera's optical centre in
  /// the motion-capture frame.
  static RgbdSequence openTum(const std::string& dir, const RgbdSequenceOptions& options = {});

  /// ICL-NUIM in its TUM-compatible release: either `depth.txt` + `rgb.txt` or an
  /// `associations.txt` (`t path t path` per line, in either order), ground truth in
  /// `groundtruth.txt` or the first `*.gt.freiburg` file. Depth scale 5000; intrinsics
  /// fx = 481.20, fy = 480.00, cx = 319.5, cy = 239.5 (the dataset's −480 has the sign of its
  /// POV-Ray y-up convention; the PNG rows run downwards).
  static RgbdSequence openIclNuim(const std::string& dir, const RgbdSequenceOptions& options = {});

  /// One 7-Scenes sequence folder (`seq-NN/`): `frame-XXXXXX.depth.png` (mm, 65535 = invalid),
  /// `frame-XXXXXX.color.png`, `frame-XXXXXX.pose.txt` (4×4 camera-to-world). The dataset has no
  /// time stamps: frame k gets k / 30 s (the Kinect's 30 Hz). Depth scale 1000, intrinsics
  /// fx = fy = 585, cx = 320, cy = 240. The colour camera is not registered to the depth camera.
  static RgbdSequence open7Scenes(const std::string& dir, const RgbdSequenceOptions& options = {});

  /// Redwood / Open3D layout: `depth/*.png` and `color/*` in name order, optional
  /// `camera_primesense.json` (or `camera_intrinsic.json`) intrinsics and `trajectory.log`
  /// camera-to-world poses, one per frame. Frame k gets k / 30 s. Depth scale 1000.
  static RgbdSequence openRedwood(const std::string& dir, const RgbdSequenceOptions& options = {});
  /// Any of the layouts above, told apart by detectDatasetKind(). A TUM or ICL-NUIM folder that
  /// carries Open3D intrinsics (`camera_intrinsic.json` or `camera_primesense.json`, as obm-sim
  /// writes them for other image sizes) uses those instead of the layout's defaults. IoError naming
  /// `dir` when it is not an RGB-D folder (a KITTI sequence, a rawlog).
  static RgbdSequence open(const std::string& dir, const RgbdSequenceOptions& options = {});
  /// A folder of a layout named by the caller (a configuration, a command line) rather than
  /// detected: the layout's factory above, and for TUM and ICL-NUIM the Open3D intrinsics file
  /// when the folder carries one, as open(dir) does.
  static RgbdSequence open(const std::string& dir, RgbdLayout layout,
                           const RgbdSequenceOptions& options = {});

  std::size_t size() const noexcept { return frames_.size(); }
  const RgbdFrame& frame(std::size_t i) const;
  const std::vector<RgbdFrame>& frames() const noexcept { return frames_; }

  const PinholeIntrinsics& intrinsics() const noexcept { return intrinsics_; }
  void setIntrinsics(const PinholeIntrinsics& intrinsics) { intrinsics_ = intrinsics; }
  /// Raw depth units per metre.
  double depthScale() const noexcept { return depth_scale_; }
  void setDepthScale(double depth_scale);
  const std::string& directory() const noexcept { return dir_; }

  /// The depth image of frame `i`.
  DepthImage depth(std::size_t i) const;

  /// Frame `i` as a cloud in the camera optical frame (timestamp = frame time), see
  /// depthToCloud(). With `with_color` the colour image (PNG or JPEG) is attached (IoError when
  /// the frame has none, FormatError when it cannot be decoded; only meaningful when colour is
  /// registered to depth; depthToCloud's ContractError when its size differs from the depth's).
  /// `edge_jump` > 0 first drops depth-edge pixels (removeDepthEdges).
  PointCloud cloud(std::size_t i, double min_depth = 0.0,
                   double max_depth = std::numeric_limits<double>::infinity(), int stride = 1,
                   bool with_color = false, double edge_jump = 0.0) const;

  /// The ground truth of the frames that have one, stamped with the depth time.
  Trajectory groundTruth() const;

 private:
  RgbdSequence() = default;
  std::string dir_;
  std::vector<RgbdFrame> frames_;
  PinholeIntrinsics intrinsics_;
  double depth_scale_ = 1000.0;
};

/// One `timestamp path` entry of a TUM list file (`rgb.txt`, `depth.txt`).
struct StampedFile {
  double t = 0.0;    ///< [s]
  std::string path;  ///< as written in the file (relative to the file's folder)
};

/// Reads a TUM list file; `#` comments and blank lines skipped. FormatError(file, line) for a
/// line that is not `number path`.
std::vector<StampedFile> readTumFileList(const std::string& path);

/// Writes a TUM list file atomically (with a `#` header line).
void writeTumFileList(const std::string& path, const std::vector<StampedFile>& entries,
                      const std::string& header = "timestamp filename");

}  // namespace obm::io
