#pragma once
/// \file dataset_kind.hpp
/// The on-disk layouts the tools play (obm-map) and export (obm-octomap), told apart by the files a
/// folder holds, so that every tool accepts a dataset as it is distributed, without conversion.
#include <string>

namespace obm::io {

enum class DatasetKind {
  Kitti,        ///< KITTI odometry sequence: velodyne/NNNNNN.bin, calib.txt, times.txt
  TumRgbd,      ///< TUM RGB-D: rgb.txt, depth.txt, groundtruth.txt
  IclNuim,      ///< ICL-NUIM (TUM-compatible release): associations.txt or *.gt.freiburg
  SevenScenes,  ///< 7-Scenes: frame-NNNNNN.{color.png,depth.png,pose.txt}
  Redwood,      ///< Redwood / Open3D: depth/ and color/ folders
  Rawlog        ///< MRPT .rawlog (optionally .gz)
};

/// "kitti", "tum-rgbd", "icl-nuim", "7scenes", "redwood", "rawlog".
std::string toString(DatasetKind kind);

/// The layout of `input` (a folder, or a .rawlog / .rawlog.gz file) from the files it holds.
/// Throws IoError naming `input` when it does not exist, is a file of another type, or no known
/// folder layout matches (the message lists what each layout needs).
DatasetKind detectDatasetKind(const std::string& input);

}  // namespace obm::io
