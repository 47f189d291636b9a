// GapFillOptions::detail_lowcut_seconds: the detail's movement slower than
// the period is taken out before it is laid, its faster movement kept, and
// the fill still meets the observed frames. On a made-up motion held still
// around one joint's gap, whose "manifold" frames turn that joint about x
// inside the gap only, so the fill's turn is the laid detail itself.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "model/gap_interpolation.h"

namespace mm {
namespace {

constexpr double kRate = 25;
constexpr int kJoint = 6;
constexpr int64_t kFrames = 300, kFirst = 100, kLast = 198;  // 99 frames: 4 s, nil again at 199

// The joint's turn about x (radians) in each frame of the gap, nil outside it.
MotionFrames manifold_turning(double (*turn)(int64_t)) {
  MotionFrames manifold;
  manifold.values.assign(static_cast<size_t>(kFrames * manifold.columns), 0.0f);
  for (int64_t f = kFirst; f <= kLast; ++f) {
    manifold.frame(f)[kRootTranslationValues + 3 * kJoint] = static_cast<float>(turn(f));
  }
  return manifold;
}

MotionFrames still_take_with_gap() {
  MotionFrames take;
  take.values.assign(static_cast<size_t>(kFrames * take.columns), 0.0f);
  for (int64_t f = kFirst; f <= kLast; ++f) {
    std::fill_n(take.frame(f) + kRootTranslationValues + 3 * kJoint, 3, std::numeric_limits<float>::quiet_NaN());
  }
  return take;
}

// One half-sine across the gap (a period of 8 s) and a wiggle of 0.2 s.
double slow_turn(int64_t f) { return 0.3 * std::sin(M_PI * static_cast<double>(f - kFirst + 1) / (kLast - kFirst + 2)); }
double fast_turn(int64_t f) { return 0.1 * std::sin(2 * M_PI * static_cast<double>(f - kFirst + 1) / 5.0); }

GapFillOptions full_detail(double lowcut_seconds) {
  GapFillOptions options;
  options.method = GapMethod::kMatched;
  options.interpolate_below_seconds = 0;
  options.few_joints_detail = {1.0, 1.0, 1.0};
  options.detail_lowcut_seconds = lowcut_seconds;
  return options;
}

// The fill's largest difference from `expected` (the x turn) over the gap.
double largest_difference(const MotionFrames& filled, double (*expected)(int64_t)) {
  double largest = 0;
  for (int64_t f = kFirst; f <= kLast; ++f) {
    const float* v = filled.frame(f) + kRootTranslationValues + 3 * kJoint;
    largest = std::max(largest, std::fabs(v[0] - expected(f)) + std::fabs(v[1]) + std::fabs(v[2]));
  }
  return largest;
}

double nil(int64_t) { return 0.0; }

TEST(DetailLowcut, OffTheWholeDetailIsLaid) {
  const MotionFrames take = still_take_with_gap();
  for (auto turn : {slow_turn, fast_turn}) {
    const MotionFrames manifold = manifold_turning(turn);
    EXPECT_LT(largest_difference(fill_gaps(take, &manifold, full_detail(0), kRate), turn), 1e-4);
  }
}

TEST(DetailLowcut, TheSlowDriftIsTakenOutAndTheFastMovementKept) {
  const MotionFrames take = still_take_with_gap();
  const MotionFrames slow = manifold_turning(slow_turn), fast = manifold_turning(fast_turn);
  // A period of 8 s through a low-cut at 1 s: 1% of its 0.3 rad is left.
  EXPECT_LT(largest_difference(fill_gaps(take, &slow, full_detail(1.0), kRate), nil), 0.01);
  // A period of 0.2 s: kept within a thousandth of a radian.
  EXPECT_LT(largest_difference(fill_gaps(take, &fast, full_detail(1.0), kRate), fast_turn), 1e-3);
}

TEST(DetailLowcut, TheFillStillMeetsTheObservedFramesAndLeavesThemAsTheyWere) {
  const MotionFrames take = still_take_with_gap();
  const MotionFrames manifold = manifold_turning(slow_turn);
  const MotionFrames filled = fill_gaps(take, &manifold, full_detail(1.0), kRate);
  for (int64_t f = 0; f < kFrames; ++f) {
    for (int c = 0; c < take.columns; ++c) {
      if (!std::isnan(take.frame(f)[c])) ASSERT_EQ(filled.frame(f)[c], take.frame(f)[c]) << "frame " << f << " column " << c;
    }
  }
  // The first and last filled frames within a small step of the still borders.
  const int column = kRootTranslationValues + 3 * kJoint;
  EXPECT_LT(std::fabs(filled.frame(kFirst)[column]), 0.01);
  EXPECT_LT(std::fabs(filled.frame(kLast)[column]), 0.01);
}

}  // namespace
}  // namespace mm
