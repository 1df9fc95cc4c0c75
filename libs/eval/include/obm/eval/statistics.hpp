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

/// Area under the ROC curve of `score` as a detector of `positive` (higher score = more likely
/// positive): the probability that a random positive scores above a random negative, ties
/// counting one half (the Mann–Whitney U statistic / (n₊·n₋)). 1 = perfect separation, 0.5 =
/// chance. NaN when either class is empty. Throws std::invalid_argument on a size mismatch.
double auroc(const std::vector<double>& score, const std::vector<bool>& positive);

}  // namespace obm::eval
