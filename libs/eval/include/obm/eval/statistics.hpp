#pragma once
/// \file statistics.hpp
/// Small descriptive statistics shared by the metrics (numpy semantics).
#include <vector>

namespace obm::eval {

/// Arithmetic mean; NaN for an empty input.
double mean(const std::vector<double>& v);
/// Median as numpy.median: the middle value, or the mean of the two middle values for an even
/// count; NaN for an empty input.
double median(std::vector<double> v);
/// sqrt(mean(v²)); NaN for an empty input.
double rootMeanSquare(const std::vector<double>& v);

}  // namespace obm::eval
