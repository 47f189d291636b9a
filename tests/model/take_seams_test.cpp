// Where a take's windows meet (model/take_seams.h), on a real S5 take and the
// shipped model: the cut shows at its seams and the crossfade does not.
#include "model/take_seams.h"

#include <gtest/gtest.h>

#include "format/motion_text.h"
#include "model/default_model.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

TEST(TakeSeams, TheCutJumpsAtItsSeamsAndTheCrossfadeMovesThereAsInsideWindows) {
  MM_REQUIRE_H36M();
  const MotionManifold model = MotionManifold::load(default_model_dir());
  // 20 s of walking at 25 Hz: windows at 0, 3, ..., 12 s and one at 14 s.
  MotionFrames take = split_phases(read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string()), 2)[0];
  take.values.resize(500 * static_cast<size_t>(take.columns));
  const TakeSeams seams = measure_take_seams(model, take, "walking_1", 3.0, model.default_decoder());
  ASSERT_EQ(seams.windows, 6);
  EXPECT_EQ(seams.window_starts.back(), 350);
  EXPECT_EQ(seams.cut.seams.transitions, 5);
  EXPECT_EQ(seams.crossfade.seams.transitions, 5);
  EXPECT_GT(seams.cut.inside.transitions, 100);
  // Measured: the cut adds 40 to 60 mm a frame at its seams, 12 mm inside
  // windows; the crossfade adds about what it adds inside. A wrong seam
  // position (the overlap's start instead of its middle) or a crossfade
  // that is not applied breaks these.
  EXPECT_GT(seams.cut.seams.excess_jump_mm, 2.5 * seams.cut.inside.excess_jump_mm);
  EXPECT_LT(seams.crossfade.seams.excess_jump_mm, 1.5 * seams.crossfade.inside.excess_jump_mm);
  EXPECT_LT(seams.crossfade.seams.jerk_mm, seams.cut.seams.jerk_mm);
  // Both joins keep the take's error near its windows' alone.
  EXPECT_GT(seams.single_clip_error_mm, 0);
  EXPECT_LT(seams.crossfade.mean_error_mm, 1.2 * seams.single_clip_error_mm);
  EXPECT_EQ(seams.crossfade.error_mm.size(), 500u);
  std::printf("seams: excess jump crossfade %.2f cut %.2f, inside %.2f mm/frame; error %.1f (crossfade) %.1f (cut) "
              "%.1f (single clips) mm\n",
              seams.crossfade.seams.excess_jump_mm, seams.cut.seams.excess_jump_mm,
              seams.crossfade.inside.excess_jump_mm, seams.crossfade.mean_error_mm, seams.cut.mean_error_mm,
              seams.single_clip_error_mm);
}

}  // namespace
}  // namespace mm
