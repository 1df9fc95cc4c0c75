#pragma once
/// \file core.hpp
/// Umbrella header of obm::core.
#include "obm/core/atomic_file.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/mesh.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/se3.hpp"
#include "obm/core/timer.hpp"
