#pragma once
/// \file eval.hpp
/// Umbrella header of obm::eval.
#include "obm/eval/kitti_odometry.hpp"
#include "obm/eval/registration_metrics.hpp"
#include "obm/eval/shape_error.hpp"
#include "obm/eval/statistics.hpp"
#include "obm/eval/trajectory_metrics.hpp"
