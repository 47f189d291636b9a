// A take's rate does not change what the manifold reads from it: a 120 Hz BVH
// made from a 25 Hz take encodes, window for window, to codes near the 25 Hz
// take's own.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/motion_resampling.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "model/default_model.h"
#include "model/take_processor.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

double distance(const std::vector<float>& a, const std::vector<float>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(sum);
}

TEST(TakeRates, A120HzBvhEncodesToTheCodesOfIts25HzTake) {
  MM_REQUIRE_H36M();
  const MotionManifold model = MotionManifold::load(default_model_dir());
  // 30 s of S5 walking at 25 Hz, and a BVH of it at 120 Hz (slerped up,
  // written with 6 decimals of degrees, read back at its own rate).
  MotionFrames take = split_phases(read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string()), 2)[0];
  take.values.resize(750 * static_cast<size_t>(take.columns));
  // 3597 frames: the 120 Hz grid reaches past the last 25 Hz frame (29.96 s),
  // so that the take is as long at 25 Hz and its windows start alike.
  const std::string bvh = h36m_motion_to_bvh_text(resample_motion(take, 25, 120, 3597), 120);
  const BvhFile file = parse_bvh_text(bvh, "walking_1_120hz.bvh");
  ASSERT_NEAR(1.0 / file.frame_time_s, 120.0, 1e-6);
  const MotionFrames at_120 = skeleton_motion_from_bvh_at_file_rate(Skeleton::h36m(), file, "walking_1_120hz.bvh");

  TakeOptions options;
  options.operation = TakeOperation::kEncode;
  options.frame_rate = 25;
  const TakeResult own = process_take(model, take, options);
  options.frame_rate = 120;
  const TakeResult fast = process_take(model, at_120, options);
  ASSERT_EQ(own.windows.size(), fast.windows.size());
  double largest = 0, typical = 0;
  for (size_t k = 0; k < own.windows.size(); ++k) {
    EXPECT_EQ(own.windows[k].start_seconds, fast.windows[k].start_seconds);
    largest = std::max(largest, distance(own.windows[k].code, fast.windows[k].code));
    if (k > 0) typical += distance(own.windows[k].code, own.windows[k - 1].code) / (own.windows.size() - 1);
  }
  // Measured with the shipped model: 0.0073 apart at most, where neighbouring windows' codes (3 s
  // apart) are 2.20 apart: the corner the 120 -> 25 Hz slerp cuts
  // (format/motion_resampling.h) and the BVH's 6 decimals move a code by
  // a third of a percent of the distance between windows.
  std::printf("codes of the 120 Hz BVH against the 25 Hz take: at most %.4f apart; neighbouring windows %.2f apart\n",
              largest, typical);
  EXPECT_LT(largest, 0.03);
  EXPECT_LT(largest, 0.01 * typical);
}

}  // namespace
}  // namespace mm
