// Frame rates as a user wrote them: a BVH's "Frame Time: 0.00833333" is
// 120.000048 Hz in binary, which a file that says 120 Hz should not show.
// Torch-free; pure functions.
#pragma once

#include <cmath>

namespace mm::client {

// `hz` rounded to 3 decimals when it lies within 1e-4 Hz of that (120 for
// 120.000048, 29.97 for 29.9700001), else `hz` as it is.
inline double shown_frame_rate(double hz) {
  const double rounded = std::round(hz * 1000.0) / 1000.0;
  return std::abs(hz - rounded) < 1e-4 ? rounded : hz;
}

}  // namespace mm::client
