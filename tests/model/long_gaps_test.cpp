// Gaps longer than the bridge (GapFillOptions::max_bridged_seconds): the
// take path answers a streamed take's frames within the bridge of their
// arrival however long a joint stays missing, and fills them exactly as the
// whole-take fill does, on a smooth made-up motion whose "manifold" frames
// differ from it (what is compared is where each frame's fill comes from,
// not how near it is to a recording).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "model/gap_interpolation.h"
#include "model/borrowed_motion.h"
#include "model/take_gap_filler.h"

namespace mm {
namespace {

constexpr double kRate = 25;

// Every joint turning smoothly, each at its own pace and phase; `offset`
// shifts the phases (the "manifold" is the motion with another offset).
MotionFrames smooth_motion(int64_t frames, double offset) {
  MotionFrames motion;
  motion.values.resize(static_cast<size_t>(frames * motion.columns));
  for (int64_t f = 0; f < frames; ++f) {
    for (int c = 0; c < motion.columns; ++c) {
      motion.frame(f)[c] = static_cast<float>(0.4 * std::sin(0.05 * f * (1 + c % 5) + 0.7 * c + offset));
    }
  }
  return motion;
}

void make_missing(MotionFrames& motion, int joint, int64_t first, int64_t last) {
  for (int64_t f = first; f <= last; ++f) {
    std::fill_n(motion.frame(f) + kRootTranslationValues + 3 * joint, 3, std::numeric_limits<float>::quiet_NaN());
  }
}

MotionFrames frames_of(const MotionFrames& motion, int64_t first, int64_t count) {
  MotionFrames part;
  part.columns = motion.columns;
  part.values.assign(motion.frame(first), motion.frame(first) + count * motion.columns);
  return part;
}

// `take` pushed through the take path's filler `batch` frames at a time,
// `manifold` as the model's frames, and what it hands out.
MotionFrames streamed_fill(const MotionFrames& take, const MotionFrames& manifold, const GapFillOptions& options,
                           int64_t batch) {
  const int64_t frames = take.frame_count();
  TakeGapFiller filler(take.columns, options, kRate);
  MotionFrames streamed;
  streamed.columns = take.columns;
  for (int64_t f = 0; f < frames; f += batch) {
    const int64_t count = std::min(batch, frames - f);
    filler.push(frames_of(take, f, count), frames_of(manifold, f, count), streamed);
  }
  filler.finish(streamed);
  return streamed;
}

double angle_between_frames(const MotionFrames& motion, int joint, int64_t a, int64_t b) {
  const int column = kRootTranslationValues + 3 * joint;
  return expmap_angle_between(motion.frame(a) + column, motion.frame(b) + column);
}

// 48 s: joint 5 lost for 16 s in the middle, joint 7 for the first 12 s,
// joint 9 from 28 s to the end, joint 3 throughout, and every joint for
// 3.6 s (a gap under the bridge, filled as ever).
MotionFrames gapped_take(int64_t frames) {
  MotionFrames take = smooth_motion(frames, 0.0);
  make_missing(take, 5, 100, 499);
  make_missing(take, 7, 0, 299);
  make_missing(take, 9, 700, frames - 1);
  make_missing(take, 3, 0, frames - 1);
  for (int j = 0; j < 32; ++j) make_missing(take, j, 550, 639);
  return take;
}

TEST(LongGaps, TheTakePathFillsThemAsTheWholeTakeFillDoesWhateverTheBatch) {
  const int64_t frames = 1200;
  const MotionFrames take = gapped_take(frames);
  const MotionFrames manifold = smooth_motion(frames, 1.3);
  for (const GapMethod method : {GapMethod::kMatched, GapMethod::kBorrowed, GapMethod::kCubic, GapMethod::kHold}) {
    for (const std::array<double, 2> gain : {std::array<double, 2>{1.0, 1.0}, std::array<double, 2>{0.5, 2.0}}) {
      GapFillOptions options;
      options.method = method;
      options.speed_gain_range = gain;
      const MotionFrames whole = fill_gaps(take, &manifold, options, kRate);
      for (const int64_t batch : {1, 7, 150}) {
        SCOPED_TRACE(testing::Message() << gap_method_name(method) << ", gain up to " << gain[1] << ", batch " << batch);
        const MotionFrames streamed = streamed_fill(take, manifold, options, batch);
        ASSERT_EQ(streamed.frame_count(), frames);
        for (size_t i = 0; i < whole.values.size(); ++i) {
          if (i % take.columns < kRootTranslationValues) continue;  // the filler takes the manifold's root
          ASSERT_TRUE(std::isfinite(streamed.values[i])) << i;
          ASSERT_NEAR(streamed.values[i], whole.values[i], 1e-5) << "frame " << i / take.columns << ", column "
                                                                  << i % take.columns;
        }
      }
    }
  }
}

// The borrowed fill streamed: a take that repeats itself (every joint's
// turning has a period of about 126 frames) with every joint missing for
// 3.6 s near its start (too little before it: its stretch lies after it)
// and again later, and two joints over 3.2 s, one of them for its first
// 2 s only, every span answered by the take's own stretches; the filler,
// waiting for the 10 s after a span (not only after each joint's gap) and
// keeping the 60 s before, hands out what the whole-take fill gives,
// whatever the batch.
TEST(LongGaps, TheBorrowedFillStreamsAsTheWholeTakeFillDoesWhateverTheBatch) {
  const int64_t frames = 1200;
  MotionFrames take = smooth_motion(frames, 0.0);
  make_missing(take, 5, 300, 349);
  make_missing(take, 7, 330, 379);  // one span with joint 5's, ending after it
  for (int j = 0; j < 32; ++j) {
    make_missing(take, j, 40, 129);
    make_missing(take, j, 550, 639);
  }
  const MotionFrames manifold = smooth_motion(frames, 1.3);
  const GapFillOptions options;
  ASSERT_EQ(options.method, GapMethod::kBorrowed);
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(take, kRate, options.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 3u);
  for (const BorrowedSpan& span : spans) EXPECT_TRUE(span.used) << span.span.first << ": " << span.cost;
  EXPECT_GT(spans[0].source_left, spans[0].span.last);
  const MotionFrames whole = fill_gaps(take, &manifold, options, kRate);
  for (const int64_t batch : {1, 7, 150}) {
    SCOPED_TRACE(batch);
    const MotionFrames streamed = streamed_fill(take, manifold, options, batch);
    ASSERT_EQ(streamed.frame_count(), frames);
    for (size_t i = 0; i < whole.values.size(); ++i) {
      if (i % take.columns < kRootTranslationValues) continue;
      ASSERT_NEAR(streamed.values[i], whole.values[i], 1e-5) << "frame " << i / take.columns << ", column "
                                                              << i % take.columns;
    }
  }
}

TEST(LongGaps, AJointLostForGoodHoldsNoFrameLongerThanTheBridge) {
  const int64_t frames = 1500;
  MotionFrames take = smooth_motion(frames, 0.0);
  make_missing(take, 5, 100, frames - 1);
  const MotionFrames manifold = smooth_motion(frames, 1.3);
  for (const GapMethod method : {GapMethod::kMatched, GapMethod::kBorrowed}) {
    SCOPED_TRACE(gap_method_name(method));
    GapFillOptions options;
    options.method = method;
    const int64_t bridge = max_bridged_frames(options, kRate);
    EXPECT_EQ(bridge, 250);
    // The borrowed fill also keeps the past it searches (60 s).
    const int64_t kept = method == GapMethod::kBorrowed ? std::lround(options.borrow.search_seconds * kRate) + 2 : 0;
    TakeGapFiller filler(take.columns, options, kRate);
    MotionFrames streamed;
    streamed.columns = take.columns;
    for (int64_t f = 0; f < frames; f += 10) {
      filler.push(frames_of(take, f, 10), frames_of(manifold, f, 10), streamed);
      // Before the bridge, every frame but the gap's left border and the
      // frame before it was held from frame 98 until the take ended.
      ASSERT_GE(streamed.frame_count(), f + 10 - bridge - 2) << "after frame " << f + 9;
      ASSERT_LE(filler.held_frames(), bridge + 2 + 10 + kept);
    }
    filler.finish(streamed);
    EXPECT_EQ(streamed.frame_count(), frames);
  }
}

TEST(LongGaps, TheBridgeStartsWhereTheHeadEndsAndMeetsTheRecording) {
  const int64_t frames = 1200;
  const MotionFrames take = gapped_take(frames);
  const MotionFrames manifold = smooth_motion(frames, 1.3);
  GapFillOptions cubic;
  cubic.method = GapMethod::kCubic;
  const MotionFrames held = fill_gaps(take, &manifold, cubic, kRate);
  // Joint 5 (frames 100..499): the cubic holds the left border for the
  // head, 100..249, then bridges 250..499 to the right border.
  const int column = kRootTranslationValues + 3 * 5;
  for (int64_t f = 100; f <= 249; ++f) {
    for (int i = 0; i < 3; ++i) ASSERT_EQ(held.frame(f)[column + i], take.frame(99)[column + i]) << f;
  }
  EXPECT_GT(angle_between_frames(held, 5, 249, 499), 0.05);  // the bridge moves
  GapFillOptions by_matching;
  by_matching.method = GapMethod::kMatched;
  const MotionFrames matched = fill_gaps(take, &manifold, by_matching, kRate);
  for (const MotionFrames* fill : {&held, &matched}) {
    // No step across the head's end or into the recording larger than the
    // motion's own largest step (0.4 rad amplitude, 0.25 rad/frame at most
    // for the fastest column: a jump would be a turn of most of a radian).
    double largest = 0;
    for (int64_t f = 99; f <= 500; ++f) largest = std::max(largest, angle_between_frames(*fill, 5, f, f + 1));
    EXPECT_LT(largest, 0.25);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(fill->frame(500)[column + i], take.frame(500)[column + i]);
  }
  // The matched head: the left border turned as the manifold turned since
  // its own left border (full weight for one joint).
  const double turned = angle_between_frames(manifold, 5, 99, 200);
  EXPECT_NEAR(angle_between_frames(matched, 5, 99, 200), turned, 1e-4);
}

}  // namespace
}  // namespace mm
