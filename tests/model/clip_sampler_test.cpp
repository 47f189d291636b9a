// The training clips (model/clip_sampler.h) with a mirror set: about half
// are mirrored, each the normalised frames of the recording's mirror image,
// and a sampler without a mirror draws the clips it always drew.
#include "model/clip_sampler.h"

#include <gtest/gtest.h>

#include <cmath>

#include "format/motion_text.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

TEST(ClipSampler, WithAMirrorHalfTheClipsAreTheRecordingsMirrorImage) {
  MM_REQUIRE_H36M();
  MotionFrames walk;
  const MotionFrames file = read_motion_text((test::h36m_dataset_dir() / "S1" / "walking_1.txt").string());
  walk.columns = file.columns;
  for (int64_t f = 0; f < file.frame_count(); f += 2) walk.values.insert(walk.values.end(), file.frame(f), file.frame(f) + file.columns);
  PreparedSequence sequence;
  const PoseNormalization normalization = PoseNormalization::fit({&walk});
  sequence.normalized = normalization.normalize(walk);
  const MotionMirror mirror = motion_mirror(Skeleton::h36m());

  ClipSampler plain({&sequence}, 150, 7), mirroring({&sequence}, 150, 7), again({&sequence}, 150, 7);
  mirroring.set_mirror(normalized_mirror(mirror, normalization));
  int mirrored_clips = 0;
  const int draws = 400;
  for (int i = 0; i < draws; ++i) {
    const ClipSampler::Clip a = plain.draw(), b = again.draw();
    EXPECT_EQ(a.start, b.start);  // no mirror: the draws of a run without one
    EXPECT_FALSE(a.mirrored);
    const ClipSampler::Clip clip = mirroring.draw();
    mirrored_clips += clip.mirrored ? 1 : 0;
    if (i % 40 != 0) continue;
    // The gathered clip against the recording's frames mirrored and normalised.
    ClipSampler::Clip both = clip;
    both.mirrored = true;
    const at::Tensor got = mirroring.gather({both});
    MotionFrames raw;
    raw.columns = walk.columns;
    raw.values.assign(walk.frame(clip.start), walk.frame(clip.start + 150));
    const MotionFrames expected = normalization.normalize(mirrored(mirror, raw));
    const float* g = got.data_ptr<float>();
    double largest = 0;
    for (size_t k = 0; k < expected.values.size(); ++k) largest = std::max(largest, static_cast<double>(std::fabs(g[k] - expected.values[k])));
    EXPECT_LT(largest, 1e-3) << "clip from " << clip.start;
  }
  EXPECT_NEAR(mirrored_clips, draws / 2, 50);  // 5 standard deviations of a fair coin
}

}  // namespace
}  // namespace mm
