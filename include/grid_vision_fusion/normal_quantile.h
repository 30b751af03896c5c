// The standard normal quantile (the inverse of the normal CDF) of the grid filter's table of
// normal samples and of the detection noise's truncated normal draws: Boost.Math's, accurate to
// a few units in the last place over the whole of (0, 1), tails included.
#pragma once

#include <boost/math/distributions/normal.hpp>

#include <stdexcept>
#include <string>

namespace grid_vision_fusion
{
/// The standard normal quantile x, P(Z <= x) = p, for p in (0, 1); normalQuantile(1 - p) =
/// -normalQuantile(p). @throws std::domain_error when p is not in (0, 1): 0, 1 (whose quantiles
/// are infinite) and NaN included.
inline double normalQuantile(double p)
{
  if (!(p > 0.0 && p < 1.0))
  {
    throw std::domain_error("normalQuantile: p = " + std::to_string(p) + " is not in (0, 1)");
  }
  return boost::math::quantile(boost::math::normal_distribution<double>(), p);
}

}  // namespace grid_vision_fusion
