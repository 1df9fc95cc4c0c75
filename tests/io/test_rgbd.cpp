// Depth / colour PNG, intrinsics, back-projection and the RGB-D sequence layouts (TUM, ICL-NUIM,
// 7-Scenes, Redwood/Open3D), on the real Open3D and TUM frames and on small folders written here.
#include <gtest/gtest.h>
#include <mrpt/img/CImage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/redwood_log.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;
namespace fs = std::filesystem;

namespace {

std::string o3dDir() {
  return test::sharedDataDir() + "/rgbd_open3d";
}

void writeText(const std::string& path, const std::string& s) {
  std::ofstream os(path, std::ios::binary);
  os << s;
}

/// Decodes with MRPT's CImage (OpenCV underneath): an independent PNG decoder to compare with.
void expectSameAsMrptDecoder(const std::string& path, const DepthImage& img) {
  mrpt::img::CImage ref;
  ASSERT_TRUE(ref.loadFromFile(path, -1)) << path;
  ASSERT_EQ(ref.getPixelDepth(), mrpt::img::PixelDepth::D16U);
  ASSERT_EQ(static_cast<int>(ref.getWidth()), img.width);
  ASSERT_EQ(static_cast<int>(ref.getHeight()), img.height);
  std::size_t differ = 0;
  for (int v = 0; v < img.height; ++v) {
    // Row pointer + column index: MRPT's at<T>(col, row) does not scale the column by the
    // 2-byte sample size.
    const std::uint16_t* row = ref.ptr<std::uint16_t>(0, static_cast<unsigned>(v));
    for (int u = 0; u < img.width; ++u)
      if (row[u] != img.at(u, v) && ++differ < 4)
        ADD_FAILURE() << path << " (" << u << ", " << v << "): " << img.at(u, v) << " vs "
                      << row[u];
  }
  EXPECT_EQ(differ, 0u) << path;
}

DepthImage constantDepth(int w, int h, std::uint16_t raw) {
  DepthImage d;
  d.width = w;
  d.height = h;
  d.data.assign(static_cast<std::size_t>(w) * h, raw);
  return d;
}

/// Median over points of the distance to the nearest point of `b` (brute force; small clouds).
double medianNearest(const PointCloud& a, const PointCloud& b) {
  std::vector<double> d;
  for (const auto& p : a.points) {
    float best = std::numeric_limits<float>::max();
    for (const auto& q : b.points) best = std::min(best, (p - q).squaredNorm());
    d.push_back(std::sqrt(best));
  }
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

}  // namespace

TEST(Intrinsics, Open3dPrimesenseJsonAndRoundTrip) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/camera_primesense.json");
  const PinholeIntrinsics K = readOpen3dIntrinsics(o3dDir() + "/camera_primesense.json");
  // Values stated by the data README (fx = fy = 525, cx = 319.5, cy = 239.5, 640×480).
  EXPECT_EQ(K.width, 640);
  EXPECT_EQ(K.height, 480);
  EXPECT_EQ(K.fx, 525.0);
  EXPECT_EQ(K.fy, 525.0);
  EXPECT_EQ(K.cx, 319.5);
  EXPECT_EQ(K.cy, 239.5);
  EXPECT_EQ(K.K()(0, 2), 319.5);
  EXPECT_EQ(K.K()(2, 2), 1.0);

  const std::string dir = test::scratchDir("intrinsics");
  const PinholeIntrinsics odd{320, 240, 260.25, 261.5, 160.125, 119.75};
  writeOpen3dIntrinsics(dir + "/k.json", odd);
  const PinholeIntrinsics back = readOpen3dIntrinsics(dir + "/k.json");
  EXPECT_EQ(back.width, 320);
  EXPECT_EQ(back.fy, 261.5);
  EXPECT_EQ(back.cx, 160.125);
  EXPECT_EQ(back.cy, 119.75);

  writeText(dir + "/bad.json", "{\"width\": 640, \"height\": 480}");
  try {
    readOpen3dIntrinsics(dir + "/bad.json");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsic_matrix"), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), dir + "/bad.json");
  }
  writeText(dir + "/broken.json", "{\"width\": 640,");
  EXPECT_THROW(readOpen3dIntrinsics(dir + "/broken.json"), FormatError);
  EXPECT_THROW(readOpen3dIntrinsics(dir + "/none.json"), IoError);
}

TEST(DepthPng, RealOpen3dDepthImages) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/depth");
  const PinholeIntrinsics K = readOpen3dIntrinsics(o3dDir() + "/camera_primesense.json");
  for (int k = 0; k < 5; ++k) {
    const std::string path = o3dDir() + "/depth/0000" + std::to_string(k) + ".png";
    SCOPED_TRACE(path);
    const DepthImage d = readDepthPng(path);
    ASSERT_EQ(d.width, 640);
    ASSERT_EQ(d.height, 480);
    expectSameAsMrptDecoder(path, d);
    const PointCloud pc = depthToCloud(d, K, 1000.0);  // millimetres
    EXPECT_EQ(pc.frame_id, "camera");
    const std::size_t valid = static_cast<std::size_t>(
        std::count_if(d.data.begin(), d.data.end(), [](std::uint16_t r) { return r != 0; }));
    EXPECT_EQ(pc.size(), valid);
    EXPECT_GT(pc.size(), 640u * 480u / 2);  // a rendered indoor scene: mostly valid
    std::vector<float> z;
    for (const auto& p : pc.points) z.push_back(p.z());
    std::sort(z.begin(), z.end());
    EXPECT_GT(z.front(), 0.2f);  // nothing closer than a depth camera's minimum range
    EXPECT_LT(z.back(), 10.0f);  // an indoor room
    EXPECT_GT(z[z.size() / 2], 0.5f);
    EXPECT_LT(z[z.size() / 2], 5.0f);
  }
}

TEST(DepthPng, HandCheckedBackProjection) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/depth/00000.png");
  const DepthImage d = readDepthPng(o3dDir() + "/depth/00000.png");
  const PinholeIntrinsics K;  // 640×480, 525, 525, 319.5, 239.5
  // A pixel in the lower right quadrant: x and y both positive in the optical frame.
  int u = 500, v = 400;
  while (d.at(u, v) == 0 && u < 639) ++u;
  ASSERT_NE(d.at(u, v), 0);
  const double z = d.at(u, v) / 1000.0;
  const Eigen::Vector3d expected((u - 319.5) * z / 525.0, (v - 239.5) * z / 525.0, z);
  DepthImage one = constantDepth(640, 480, 0);
  one.at(u, v) = d.at(u, v);
  const PointCloud pc = depthToCloud(one, K, 1000.0);
  ASSERT_EQ(pc.size(), 1u);
  EXPECT_LT((pc.points[0].cast<double>() - expected).norm(), 1e-6);
  EXPECT_GT(pc.points[0].x(), 0.f);
  EXPECT_GT(pc.points[0].y(), 0.f);
  // The principal point back-projects onto the optical axis.
  DepthImage c = constantDepth(2, 2, 2000);
  const PointCloud axis = depthToCloud(c, PinholeIntrinsics{2, 2, 100.0, 100.0, 0.0, 0.0}, 1000.0);
  ASSERT_EQ(axis.size(), 4u);
  EXPECT_EQ(axis.points[0], Vector3f(0, 0, 2));
  EXPECT_EQ(axis.points[3], Vector3f(0.02f, 0.02f, 2.f));
}

TEST(DepthPng, RangeStrideInvalidAndColour) {
  DepthImage d = constantDepth(8, 6, 1000);
  d.at(0, 0) = 0;
  d.at(1, 0) = 65535;  // 7-Scenes' "invalid"
  d.at(2, 0) = 9000;   // 9 m
  d.at(3, 0) = 100;    // 0.1 m
  const PinholeIntrinsics K{8, 6, 10.0, 10.0, 3.5, 2.5};
  EXPECT_EQ(depthToCloud(d, K, 1000.0).size(), 48u - 2u);
  EXPECT_EQ(depthToCloud(d, K, 1000.0, 0.2, 5.0).size(), 48u - 4u);
  // stride 2 visits columns 0,2,4,6 of rows 0,2,4: 12 pixels, two of them (0,0), (2,0) special.
  EXPECT_EQ(depthToCloud(d, K, 1000.0, 0.0, 5.0, 2).size(), 10u);
  ColorImage col;
  col.width = 8;
  col.height = 6;
  col.rgb.assign(8 * 6 * 3, 0);
  for (std::size_t k = 0; k < col.rgb.size(); ++k) col.rgb[k] = static_cast<std::uint8_t>(k % 251);
  const PointCloud pc = depthToCloud(d, K, 1000.0, 0.0, 100.0, 1, &col);
  ASSERT_EQ(pc.colors.size(), pc.size());
  EXPECT_EQ(pc.colors[0], col.at(2, 0));  // first kept pixel
  EXPECT_THROW(depthToCloud(d, PinholeIntrinsics{}, 1000.0), ContractError);
  EXPECT_THROW(depthToCloud(d, K, 0.0), ContractError);
  EXPECT_THROW(depthToCloud(d, K, 1000.0, 0.0, 1.0, 0), ContractError);
}

TEST(DepthPng, RealTumDepthFrame) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/other_formats/TUM_depth.png");
  const std::string path = o3dDir() + "/other_formats/TUM_depth.png";
  const DepthImage d = readDepthPng(path);
  expectSameAsMrptDecoder(path, d);
  const PointCloud pc = depthToCloud(d, PinholeIntrinsics{}, 5000.0);  // TUM: 5000 per metre
  EXPECT_GT(pc.size(), 640u * 480u / 4);
  Vector3f lo, hi;
  pc.bounds(lo, hi);
  EXPECT_GT(lo.z(), 0.3f);  // Kinect v1 working range ~0.5–8 m
  EXPECT_LT(hi.z(), 10.f);
  // Read with the wrong scale (millimetres) the same room would be 5× deeper.
  Vector3f lo2, hi2;
  depthToCloud(d, PinholeIntrinsics{}, 1000.0).bounds(lo2, hi2);
  EXPECT_NEAR(hi2.z() / hi.z(), 5.0, 1e-4);
  // The colour frame is an 8-bit RGB PNG: not a depth image.
  EXPECT_THROW(readDepthPng(o3dDir() + "/other_formats/TUM_color.png"), FormatError);
  const ColorImage c = readColorPng(o3dDir() + "/other_formats/TUM_color.png");
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_EQ(c.rgb.size(), 640u * 480u * 3u);
}

TEST(DepthPng, RoundTripsAndCorruptFiles) {
  const std::string dir = test::scratchDir("png_rt");
  DepthImage d = constantDepth(37, 23, 0);
  for (std::size_t k = 0; k < d.data.size(); ++k)
    d.data[k] = static_cast<std::uint16_t>((k * 2654435761u) & 0xFFFF);
  d.data[0] = 0;
  d.data[1] = 65535;
  d.data[2] = 1;
  d.data[3] = 256;
  writeDepthPng(dir + "/d.png", d);
  const DepthImage back = readDepthPng(dir + "/d.png");
  EXPECT_EQ(back.width, 37);
  EXPECT_EQ(back.height, 23);
  EXPECT_EQ(back.data, d.data);
  expectSameAsMrptDecoder(dir + "/d.png", d);  // byte order as other decoders expect

  ColorImage c;
  c.width = 5;
  c.height = 3;
  for (int k = 0; k < 45; ++k) c.rgb.push_back(static_cast<std::uint8_t>(k * 5));
  writeColorPng(dir + "/c.png", c);
  const ColorImage cb = readColorPng(dir + "/c.png");
  EXPECT_EQ(cb.rgb, c.rgb);
  EXPECT_THROW(readDepthPng(dir + "/c.png"), FormatError);
  // A 16-bit depth PNG read as colour is reduced to 8 bits and greyscale expanded to RGB.
  const ColorImage dc = readColorPng(dir + "/d.png");
  EXPECT_EQ(dc.at(1, 0), Color3u8(255, 255, 255));

  // Truncated PNG: an exception naming the file, no crash.
  std::ifstream is(dir + "/d.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  writeText(dir + "/trunc.png", bytes.substr(0, bytes.size() / 2));
  try {
    readDepthPng(dir + "/trunc.png");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.file(), dir + "/trunc.png");
  }
  writeText(dir + "/text.png", "not an image at all");
  EXPECT_THROW(readDepthPng(dir + "/text.png"), FormatError);
  EXPECT_THROW(readDepthPng(dir + "/missing.png"), IoError);
  EXPECT_THROW(writeDepthPng(dir + "/no_such_folder/x.png", d), IoError);
  DepthImage wrong = d;
  wrong.data.pop_back();
  EXPECT_THROW(writeDepthPng(dir + "/w.png", wrong), ContractError);
  EXPECT_FALSE(fs::exists(dir + "/w.png"));
}

TEST(RgbdSequence, TumFolderAssociatesByTimestamp) {
  // A small TUM layout: depth at ~30 Hz, colour a few ms off (one colour frame missing),
  // motion-capture ground truth at 100 Hz.
  const std::string dir = test::scratchDir("tum_folder");
  fs::create_directories(dir + "/depth");
  fs::create_directories(dir + "/rgb");
  const double t0 = 1305031102.0;
  std::vector<StampedFile> depth_list, rgb_list;
  for (int k = 0; k < 4; ++k) {
    const double td = t0 + k / 30.0;
    const std::string name = "depth/" + std::to_string(k) + ".png";
    writeDepthPng(dir + "/" + name,
                  constantDepth(16, 12, static_cast<std::uint16_t>(5000 + 500 * k)));
    depth_list.push_back({td, name});
    if (k == 2) continue;  // no colour for this one
    const std::string cname = "rgb/" + std::to_string(k) + ".png";
    ColorImage c;
    c.width = 16;
    c.height = 12;
    c.rgb.assign(16 * 12 * 3, static_cast<std::uint8_t>(40 * k));
    writeColorPng(dir + "/" + cname, c);
    rgb_list.push_back({td + 0.004 * (k % 2 ? 1 : -1), cname});
  }
  std::reverse(depth_list.begin(), depth_list.end());  // list order must not matter
  writeTumFileList(dir + "/depth.txt", depth_list, "depth maps");
  writeTumFileList(dir + "/rgb.txt", rgb_list, "color images");
  Trajectory gt;
  for (int k = -5; k < 20; ++k)
    gt.push_back({t0 + 0.01 * k + 0.001,
                  makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.01 * k, 0, 0))});
  writeTumTrajectory(dir + "/groundtruth.txt", gt);

  RgbdSequence seq = RgbdSequence::openTum(dir);
  ASSERT_EQ(seq.size(), 4u);
  EXPECT_EQ(seq.depthScale(), 5000.0);
  EXPECT_EQ(seq.intrinsics().fx, 525.0);
  for (std::size_t k = 0; k < 4; ++k) {
    const RgbdFrame& f = seq.frame(k);
    EXPECT_NEAR(f.timestamp, t0 + k / 30.0, 1e-6);  // sorted by time
    EXPECT_EQ(fs::path(f.depth_path).filename(), std::to_string(k) + ".png");
    if (k == 2) {
      EXPECT_TRUE(f.color_path.empty());
    } else {
      EXPECT_EQ(fs::path(f.color_path).filename(), std::to_string(k) + ".png");
      EXPECT_NEAR(f.color_timestamp - f.timestamp, 0.004 * (k % 2 ? 1 : -1), 1e-6);
    }
    // Nearest ground truth: the 100 Hz sample closest to k/30 s.
    ASSERT_TRUE(f.has_pose);
    const double nearest = std::round((k / 30.0 - 0.001) / 0.01);
    EXPECT_NEAR(f.T_world_camera.translation().x(), 0.01 * nearest, 1e-12);
  }
  EXPECT_EQ(seq.groundTruth().size(), 4u);

  // open(): the layout is detected; Open3D intrinsics in the folder override the TUM defaults.
  EXPECT_EQ(RgbdSequence::open(dir).intrinsics().fx, 525.0);
  writeOpen3dIntrinsics(dir + "/camera_intrinsic.json",
                        PinholeIntrinsics{16, 12, 10.0, 11.0, 7.5, 5.5});
  {
    const RgbdSequence any = RgbdSequence::open(dir);
    EXPECT_EQ(any.size(), 4u);
    EXPECT_EQ(any.intrinsics().fy, 11.0);
  }
  fs::remove(dir + "/camera_intrinsic.json");
  writeText(dir + "/not_rgbd.rawlog", "");
  try {
    RgbdSequence::open(dir + "/not_rgbd.rawlog");
    FAIL() << "a rawlog is not an RGB-D folder";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("not_rgbd.rawlog"), std::string::npos) << e.what();
  }

  seq.setIntrinsics(PinholeIntrinsics{16, 12, 10.0, 10.0, 7.5, 5.5});
  const PointCloud pc = seq.cloud(1);
  EXPECT_EQ(pc.size(), 16u * 12u);
  EXPECT_EQ(pc.timestamp, seq.frame(1).timestamp);
  EXPECT_FLOAT_EQ(pc.points[0].z(), 5500.f / 5000.f);
  const PointCloud pcc = seq.cloud(3, 0.0, 10.0, 4, /*with_color=*/true);
  ASSERT_EQ(pcc.colors.size(), pcc.size());
  EXPECT_EQ(pcc.colors[0], Color3u8(120, 120, 120));
  EXPECT_THROW(seq.cloud(2, 0.0, 10.0, 1, true), IoError);  // no colour image
  EXPECT_THROW(seq.frame(4), ContractError);

  RgbdSequenceOptions opt;
  opt.require_color = true;
  EXPECT_EQ(RgbdSequence::openTum(dir, opt).size(), 3u);
  opt.require_color = false;
  opt.max_time_difference = 0.003;  // colour is 4 ms off: nothing associates
  const RgbdSequence strict = RgbdSequence::openTum(dir, opt);
  for (const auto& f : strict.frames()) EXPECT_TRUE(f.color_path.empty());

  writeText(dir + "/rgb.txt", "# c\n1305031102.0 rgb/0.png extra\n");
  try {
    RgbdSequence::openTum(dir);
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_NE(std::string(e.what()).find("rgb.txt:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(RgbdSequence::openTum(dir + "/depth"), IoError);  // no depth.txt
}

TEST(RgbdSequence, IclNuimAssociationsAndFreiburgGroundTruth) {
  const std::string dir = test::scratchDir("iclnuim");
  fs::create_directories(dir + "/depth");
  fs::create_directories(dir + "/rgb");
  std::string assoc;
  std::vector<StampedPose> gt;
  for (int k = 0; k < 3; ++k) {
    writeDepthPng(dir + "/depth/" + std::to_string(k) + ".png", constantDepth(4, 3, 5000));
    // ICL-NUIM writes the depth image first; the colour image first is accepted too.
    assoc += k == 1 ? std::to_string(k) + " rgb/" + std::to_string(k) + ".png " +
                          std::to_string(k) + " depth/" + std::to_string(k) + ".png\n"
                    : std::to_string(k) + " depth/" + std::to_string(k) + ".png " +
                          std::to_string(k) + " rgb/" + std::to_string(k) + ".png\n";
    gt.push_back({static_cast<double>(k),
                  makeIsometry(expSO3(Eigen::Vector3d(0, 0.1 * k, 0)), Eigen::Vector3d(k, 0, 0))});
  }
  writeText(dir + "/associations.txt", assoc);
  writeTumTrajectory(dir + "/livingRoom0.gt.freiburg", gt);
  const RgbdSequence seq = RgbdSequence::openIclNuim(dir);
  ASSERT_EQ(seq.size(), 3u);
  EXPECT_EQ(seq.intrinsics().fx, 481.20);
  EXPECT_EQ(seq.intrinsics().fy, 480.00);
  EXPECT_EQ(seq.depthScale(), 5000.0);
  EXPECT_EQ(fs::path(seq.frame(1).depth_path).filename(), "1.png");
  EXPECT_NE(seq.frame(1).depth_path.find("depth"), std::string::npos);
  EXPECT_NE(seq.frame(1).color_path.find("rgb"), std::string::npos);
  for (std::size_t k = 0; k < 3; ++k) {
    ASSERT_TRUE(seq.frame(k).has_pose);
    EXPECT_LT((seq.frame(k).T_world_camera.matrix() - gt[k].T.matrix()).cwiseAbs().maxCoeff(),
              1e-12);
  }
  writeText(dir + "/associations.txt", "0 a/0.png 0 b/0.png\n");
  EXPECT_THROW(RgbdSequence::openIclNuim(dir), FormatError);
}

TEST(RgbdSequence, SevenScenesFolder) {
  const std::string dir = test::scratchDir("seven_scenes/seq-01");
  for (int k = 0; k < 3; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame-%06d", k);
    const std::string stem = dir + "/" + name;
    DepthImage d = constantDepth(640, 480, static_cast<std::uint16_t>(1000 + k));
    d.at(0, 0) = 65535;  // 7-Scenes marks missing depth with 65535
    writeDepthPng(stem + ".depth.png", d);
    writeText(stem + ".pose.txt",
              "1 0 0 " + std::to_string(k) + "\n0 1 0 0.5\n0 0 1 -1\n0 0 0 1\n");
  }
  const RgbdSequence seq = RgbdSequence::open7Scenes(dir);
  ASSERT_EQ(seq.size(), 3u);
  EXPECT_EQ(seq.intrinsics().fx, 585.0);
  EXPECT_EQ(seq.depthScale(), 1000.0);
  EXPECT_NEAR(seq.frame(2).timestamp, 2.0 / 30.0, 1e-15);
  ASSERT_TRUE(seq.frame(2).has_pose);
  EXPECT_EQ(seq.frame(2).T_world_camera.translation(), Eigen::Vector3d(2, 0.5, -1));
  EXPECT_TRUE(seq.frame(0).color_path.empty());
  const PointCloud pc = seq.cloud(1, 0.0, 10.0, 1);
  EXPECT_EQ(pc.size(), 640u * 480u - 1u);
  EXPECT_FLOAT_EQ(pc.points[0].z(), 1.001f);

  writeText(dir + "/frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1\n0 0 0 1\n");
  try {
    RgbdSequence::open7Scenes(dir);
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 3u);
    EXPECT_NE(std::string(e.what()).find("frame-000001.pose.txt"), std::string::npos);
  }
  EXPECT_THROW(RgbdSequence::open7Scenes(test::scratchDir("seven_scenes_empty")), IoError);
}

TEST(RgbdSequence, RealOpen3dFolderWithTrajectory) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d");
  const RgbdSequence seq = RgbdSequence::openRedwood(o3dDir());
  ASSERT_EQ(seq.size(), 5u);
  EXPECT_EQ(seq.intrinsics().fx, 525.0);
  EXPECT_EQ(seq.depthScale(), 1000.0);
  EXPECT_EQ(fs::path(seq.frame(3).color_path).filename(), "00003.jpg");
  const auto traj = readRedwoodTrajectory(o3dDir() + "/trajectory.log");
  for (std::size_t k = 0; k < 5; ++k) {
    ASSERT_TRUE(seq.frame(k).has_pose);
    EXPECT_EQ(seq.frame(k).T_world_camera.matrix(), traj[k].matrix());
  }
  // The colour frames are JPEG: decoded and attached point by point.
  const ColorImage jpg = readColorJpeg(seq.frame(0).color_path);
  EXPECT_EQ(jpg.width, 640);
  EXPECT_EQ(jpg.height, 480);
  const PointCloud coloured = seq.cloud(0, 0.0, 10.0, 8, /*with_color=*/true);
  ASSERT_EQ(coloured.colors.size(), coloured.size());
  ASSERT_GT(coloured.size(), 1000u);
  double mean = 0.0, mean2 = 0.0;
  for (const auto& c : coloured.colors) {
    const double g = (double(c[0]) + c[1] + c[2]) / 3.0;
    mean += g;
    mean2 += g * g;
  }
  mean /= double(coloured.size());
  const double sd = std::sqrt(mean2 / double(coloured.size()) - mean * mean);
  EXPECT_GT(sd, 10.0) << "a rendered room is not one flat grey";
  EXPECT_GT(mean, 20.0);
  EXPECT_LT(mean, 235.0);

  // The trajectory is camera-to-world: frames 0 and 4 back-projected and moved to the world
  // overlap closely; with the inverse convention they do not.
  // Sparse queries against a dense target keep the brute-force search cheap.
  const PointCloud c0 = seq.cloud(0, 0.0, 10.0, 16), c4 = seq.cloud(4, 0.0, 10.0, 4);
  const double good =
      medianNearest(c0.transformed(traj[0], "world"), c4.transformed(traj[4], "world"));
  const double bad = medianNearest(c0.transformed(traj[0].inverse(), "world"),
                                   c4.transformed(traj[4].inverse(), "world"));
  EXPECT_LT(good, 0.02);  // measured 0.0085 m
  EXPECT_GT(bad, 3.0 * good);
}

/// readColorJpeg(path) is a FormatError whose message names the file and holds `reason`.
static void expectJpegRefused(const std::string& path, const std::string& reason) {
  try {
    readColorJpeg(path);
    ADD_FAILURE() << path << " was read as an image";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

TEST(ColorImage, FuzzFindingsJpegClaimingAHugeImageWithoutItsDataFailAtOnce) {
  // Found by tests/fuzz (scripts/fuzz.sh, libFuzzer timeouts): 219 and 380 bytes whose frame
  // headers claim 4135 x 59139 pixels and whose image data ends at once (the file ends; a marker
  // comes where pixels should). libjpeg pads the missing rows with grey, so the reader allocated
  // 730 MB and decoded 59 139 empty rows (15 s and 37 s under ASan). Image data that ends before
  // the image is now a FormatError naming the file, raised at the first missing row.
  // A third (182 bytes, progressive, 4135 x 65343 claimed): libjpeg zeroes a progressive image's
  // coefficients when decompression starts, so the size is now refused before that (7 s before).
  for (const char* name : {"header_claims_huge_image_truncated.jpg",
                           "marker_ends_data_of_huge_image.jpg",
                           "progressive_header_claims_270mpx.jpg"}) {
    const std::string path = obm::test::sourceDir() + "/tests/fuzz/regressions/jpeg/" + name;
    ASSERT_TRUE(fs::exists(path));
    const auto t0 = std::chrono::steady_clock::now();
    // (All three headers are beyond the largest image accepted, 8192 x 8192.)
    expectJpegRefused(path, "out of range");
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(s, 1.0) << name << ": refused from its header, not after decoding (a hang, not a speed target)";
  }
}

TEST(ColorImage, RealJpegCutShortIsAFormatErrorNotAGreyImage) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d");
  const std::string frame = o3dDir() + "/color/00000.jpg";
  std::ifstream in(frame, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 10000u);
  EXPECT_EQ(readColorJpeg(frame).width, 640);  // whole: read
  // The file ends mid-image; the image data ends at an end-of-image marker mid-image. libjpeg
  // would fill the rest of the image with grey (rows 264-479 here) and warn.
  const std::string dir = test::scratchDir("jpeg_cut");
  const std::string half = bytes.substr(0, bytes.size() / 2);
  for (const auto& [name, content] :
       {std::pair<std::string, std::string>{"cut.jpg", half}, {"eoi.jpg", half + "\xFF\xD9"}}) {
    const std::string path = dir + "/" + name;
    { std::ofstream(path, std::ios::binary) << content; }
    expectJpegRefused(path, "corrupt JPEG");
  }
}

TEST(ColorImage, JpegErrorsNameTheFile) {
  const std::string dir = test::scratchDir("jpeg_errors");
  const std::string not_jpeg = dir + "/not_a.jpg", truncated = dir + "/truncated.jpg";
  { std::ofstream(not_jpeg) << "hello"; }
  {
    // A JPEG start-of-image marker and then nothing usable.
    std::ofstream f(truncated, std::ios::binary);
    const unsigned char bytes[] = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10, 'J', 'F', 'I', 'F'};
    f.write(reinterpret_cast<const char*>(bytes), sizeof(bytes));
  }
  for (const std::string& path : {not_jpeg, truncated}) {
    try {
      readColorJpeg(path);
      ADD_FAILURE() << path << " was read";
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(readColorJpeg(dir + "/missing.jpg"), IoError);
  EXPECT_THROW(readColorImage(dir + "/image.bmp"), IoError);
  EXPECT_THROW(readColorImage(not_jpeg), FormatError);  // by extension: the JPEG reader
}

TEST(DepthImage, EdgePixelsOfAStepAreRemovedOnBothSides) {
  // 6×3 image: 1 m on the left half, 2 m on the right, one hole; 10 % relative jump.
  DepthImage d;
  d.width = 6;
  d.height = 3;
  d.data.assign(18, 1000);
  for (int v = 0; v < 3; ++v)
    for (int u = 3; u < 6; ++u) d.at(u, v) = 2000;
  d.at(0, 0) = 0;  // a hole next to valid depth is not an edge
  DepthImage copy = d;
  EXPECT_EQ(removeDepthEdges(copy, 0.0), 0u);  // off
  EXPECT_EQ(copy.data, d.data);
  EXPECT_EQ(removeDepthEdges(d, 0.1), 6u);  // columns 2 and 3
  for (int v = 0; v < 3; ++v) {
    EXPECT_EQ(d.at(2, v), 0);
    EXPECT_EQ(d.at(3, v), 0);
    EXPECT_EQ(d.at(1, v), 1000);
    EXPECT_EQ(d.at(4, v), 2000);
  }
  DepthImage gentle = copy;  // a 5 % slope between neighbours stays at a 10 % threshold
  for (int v = 0; v < 3; ++v)
    for (int u = 0; u < 6; ++u) gentle.at(u, v) = static_cast<std::uint16_t>(1000 + 50 * u);
  EXPECT_EQ(removeDepthEdges(gentle, 0.1), 0u);
}
