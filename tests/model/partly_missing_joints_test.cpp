// A joint is missing in a frame when any of its three exponential-map values
// is NaN (gap_interpolation.h): one whose first value is observed and whose
// second or third is not is filled whole, exactly as if all three were
// missing, by every fill. On S5 walking_1 at 25 Hz, with the recording a
// few frames on standing in for the manifold's frames (what is compared is
// the fill of the same gap given two ways, not how near it is to anything).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "format/motion_text.h"
#include "model/gap_interpolation.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

constexpr double kRate = 25;

MotionFrames walking_at_25(double seconds) {
  const MotionFrames file = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  MotionFrames take;
  take.columns = file.columns;
  for (int64_t f = 0; f < file.frame_count() && take.frame_count() < std::lround(seconds * kRate); f += 2) {
    take.values.insert(take.values.end(), file.frame(f), file.frame(f) + file.columns);
  }
  return take;
}

// Values `values` (0, 1, 2) of `joints` made NaN over first..last.
void make_missing(MotionFrames& take, const std::vector<int>& joints, const std::vector<int>& values, int64_t first,
                  int64_t last) {
  for (int64_t f = first; f <= last; ++f) {
    for (int j : joints) {
      for (int v : values) take.frame(f)[kRootTranslationValues + 3 * j + v] = std::numeric_limits<float>::quiet_NaN();
    }
  }
}

std::vector<int> every_joint(const MotionFrames& take) {
  std::vector<int> joints;
  for (int j = 0; j < (take.columns - kRootTranslationValues) / 3; ++j) joints.push_back(j);
  return joints;
}

// The fill of `partly` (some of a joint's values missing) against the fill
// of `wholly` (all three missing over the same frames), by each method.
void expect_filled_as_wholly_missing(const MotionFrames& partly, const MotionFrames& wholly,
                                     const MotionFrames& manifold) {
  for (GapMethod method : {GapMethod::kBorrowed, GapMethod::kFitted, GapMethod::kMatched, GapMethod::kCubic,
                           GapMethod::kSlerp, GapMethod::kHold}) {
    GapFillOptions options;
    options.method = method;
    const MotionFrames from_partly = fill_gaps(partly, &manifold, options, kRate);
    const MotionFrames from_wholly = fill_gaps(wholly, &manifold, options, kRate);
    ASSERT_EQ(from_partly.values.size(), from_wholly.values.size());
    int64_t nan = 0, differing = 0;
    for (size_t i = 0; i < from_partly.values.size(); ++i) {
      nan += std::isnan(from_partly.values[i]) ? 1 : 0;
      differing += from_partly.values[i] != from_wholly.values[i] ? 1 : 0;
    }
    EXPECT_EQ(nan, 0) << gap_method_name(method) << ": values left missing";
    EXPECT_EQ(differing, 0) << gap_method_name(method) << ": values filled otherwise than with all three missing";
  }
}

TEST(PartlyMissingJoints, AJointMissingItsSecondOrThirdValueIsFilledAsIfAllThreeWereMissing) {
  MM_REQUIRE_H36M();
  const MotionFrames take = walking_at_25(40);
  MotionFrames manifold = take;  // the recording 7 frames on, as the manifold's frames
  for (int64_t f = 0; f + 7 < take.frame_count(); ++f) std::copy_n(take.frame(f + 7), take.columns, manifold.frame(f));
  // One joint (RightUpLeg) for 1 s (too short to borrow for: the fitted
  // fallback) and for 2 s (searched for a stretch); another (LeftArm) for 4 s.
  MotionFrames partly = take, wholly = take;
  make_missing(partly, {1}, {1}, 200, 224);
  make_missing(partly, {1}, {2}, 400, 449);
  make_missing(partly, {17}, {1, 2}, 600, 699);
  make_missing(wholly, {1}, {0, 1, 2}, 200, 224);
  make_missing(wholly, {1}, {0, 1, 2}, 400, 449);
  make_missing(wholly, {17}, {0, 1, 2}, 600, 699);
  expect_filled_as_wholly_missing(partly, wholly, manifold);
}

// Every joint missing its second value for 4 s is in-betweening, as every
// joint missing whole is: the fill lays the detail at the weight of most
// joints missing (GapFillOptions::most_joints_detail), not of a few.
TEST(PartlyMissingJoints, EveryJointMissingOneValueIsInbetweening) {
  MM_REQUIRE_H36M();
  const MotionFrames take = walking_at_25(40);
  MotionFrames manifold = take;
  for (int64_t f = 0; f + 7 < take.frame_count(); ++f) std::copy_n(take.frame(f + 7), take.columns, manifold.frame(f));
  MotionFrames partly = take, wholly = take;
  make_missing(partly, every_joint(take), {1}, 300, 399);
  make_missing(wholly, every_joint(take), {0, 1, 2}, 300, 399);
  EXPECT_TRUE(most_joints_missing(partly, 350));
  expect_filled_as_wholly_missing(partly, wholly, manifold);
}

}  // namespace
}  // namespace mm
