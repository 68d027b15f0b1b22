// shearzone/core/stats.hpp: order statistics shared by the stages.
//
// Two different "medians" are in use, kept apart by name:
//   median_inplace        the textbook median: the middle value for an odd count, the
//                         mean of the two middle values for an even count (the PIV
//                         normalised median test, as Westerweel & Scarano define it);
//   upper_median_inplace  the value at index n/2 of the sorted values: for an even
//                         count the upper of the two middle values, never an average,
//                         so the result is always one of the samples (time steps,
//                         sampling steps, peak heights, image intensities).
// percentile() interpolates linearly between order statistics (Hyndman & Fan type 7,
// numpy's default).
//
// Empty input gives NaN. NaN values have no place in the order (std::nth_element and
// std::sort need a strict weak ordering): callers pass NaN-free values.
#pragma once

#include <span>
#include <vector>

namespace shearzone::core {

/// The median of `v`: the middle value for an odd count, the mean of the two middle
/// values for an even count; NaN if `v` is empty. Reorders `v` (std::nth_element).
double median_inplace(std::span<double> v);

/// The value at index n/2 of the sorted `v` (for an even count the upper of the two
/// middle values, no averaging); NaN if `v` is empty. Reorders `v` (std::nth_element).
double upper_median_inplace(std::span<double> v);
float upper_median_inplace(std::span<float> v);

/// The q-quantile of `v`, 0 <= q <= 1: with s the sorted values and p = q (n-1), the
/// linear interpolation between s[floor(p)] and the next one; NaN if `v` is empty.
double percentile(std::vector<double> v, double q);

}  // namespace shearzone::core
