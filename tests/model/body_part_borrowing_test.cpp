// The borrowed fill searching the legs and the upper body apart
// (BorrowOptions::parts, body_parts()): which joints each part holds, on the
// H3.6M skeleton and on rigs of other shapes, and a made-up take whose legs
// repeat at one pace and whose upper body at another, so that no stretch of
// the whole body is like a gap's surroundings but one of each part is.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "model/borrowed_motion.h"
#include "model/gap_interpolation.h"
#include "model/take_gap_filler.h"

namespace mm {
namespace {

constexpr double kRate = 25;

std::vector<int> range(int first, int last) {
  std::vector<int> joints;
  for (int j = first; j <= last; ++j) joints.push_back(j);
  return joints;
}

Skeleton skeleton_of(const std::vector<int>& parents) {
  Skeleton skeleton;
  for (size_t j = 0; j < parents.size(); ++j) skeleton.joints.push_back({"j" + std::to_string(j), parents[j], {0, 10, 0}});
  return skeleton;
}

TEST(BodyPartBorrowing, TheLegsWithTheRootAndTheUpperBody) {
  const auto h36m = body_parts(Skeleton::h36m());
  ASSERT_EQ(h36m.size(), 2u);
  EXPECT_EQ(h36m[0], range(0, 10));   // Hips, both legs to the toes
  EXPECT_EQ(h36m[1], range(11, 31));  // Spine up: the head and both arms
  // A root above a pelvis (as CMU's rigs: Hips, then the hip joints and the
  // lower back), the upper body listed before the legs: the chain to the
  // pelvis goes with the legs, the pelvis's largest branch is the upper body.
  //   0 root - 1 pelvis - 2 spine - 3 chest - {4 neck - 5 head, 6 arm - 7 hand}
  //                     - 8 leg - 9 foot,  10 leg - 11 foot
  const auto rig = body_parts(skeleton_of({-1, 0, 1, 2, 3, 4, 3, 6, 1, 8, 1, 10}));
  ASSERT_EQ(rig.size(), 2u);
  EXPECT_EQ(rig[0], (std::vector<int>{0, 1, 8, 9, 10, 11}));
  EXPECT_EQ(rig[1], range(2, 7));
  // A chain has no parts: the whole body is searched at once.
  EXPECT_TRUE(body_parts(skeleton_of({-1, 0, 1, 2})).empty());
}

void make_missing(MotionFrames& motion, int joint, int64_t first, int64_t last) {
  for (int64_t f = first; f <= last; ++f) {
    std::fill_n(motion.frame(f) + kRootTranslationValues + 3 * joint, 3, std::numeric_limits<float>::quiet_NaN());
  }
}

// Every joint turning smoothly, the legs (joints 0 to 10) with a period of
// 100 frames, the upper body with one of 60: within a 24 s take the two
// never line up as they do around its gap.
MotionFrames two_paced_motion(int64_t frames) {
  MotionFrames motion;
  motion.values.resize(static_cast<size_t>(frames * motion.columns));
  for (int64_t f = 0; f < frames; ++f) {
    for (int c = kRootTranslationValues; c < motion.columns; ++c) {
      const int joint = (c - kRootTranslationValues) / 3;
      const double period = joint <= 10 ? 100.0 : 60.0;
      motion.frame(f)[c] = static_cast<float>(0.6 * std::sin(2 * M_PI * static_cast<double>(f) / period + 0.7 * c));
    }
  }
  return motion;
}

// The mean angle (rad) between `filled` and `truth` over frames [first, last].
double mean_angle(const MotionFrames& filled, const MotionFrames& truth, int64_t first, int64_t last) {
  double sum = 0;
  int64_t count = 0;
  for (int64_t f = first; f <= last; ++f) {
    for (int j = 0; j < 32; ++j) {
      const int column = kRootTranslationValues + 3 * j;
      sum += expmap_angle_between(filled.frame(f) + column, truth.frame(f) + column);
      ++count;
    }
  }
  return sum / static_cast<double>(count);
}

TEST(BodyPartBorrowing, EachPartBorrowsItsOwnStepsWhereNoStretchOfTheWholeBodyIsLikeTheGap) {
  const int64_t frames = 600, first = 300, last = 374;  // every joint missing for 3 s
  const MotionFrames truth = two_paced_motion(frames);
  MotionFrames take = truth;
  for (int j = 0; j < 32; ++j) make_missing(take, j, first, last);
  // The fitted fill's frames where nothing is borrowed: another motion.
  MotionFrames manifold = two_paced_motion(frames);
  for (float& v : manifold.values) v = -v;

  GapFillOptions whole_body;
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(take, kRate, whole_body.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 1u);
  EXPECT_FALSE(spans[0].used) << spans[0].cost;

  // The whole body searched first, as alone; then each part.
  GapFillOptions by_parts;
  by_parts.borrow.parts = body_parts(Skeleton::h36m());
  borrow_take_motion(take, kRate, by_parts.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 3u);
  EXPECT_EQ(spans[0].part, -1);
  EXPECT_FALSE(spans[0].used);
  spans.erase(spans.begin());
  for (const BorrowedSpan& span : spans) {
    SCOPED_TRACE(span.part);
    EXPECT_TRUE(span.used) << span.cost;
    EXPECT_LT(span.cost, 0.001);
  }
  EXPECT_EQ(spans[0].part, 0);
  EXPECT_EQ(spans[1].part, 1);
  // Each part's source is a whole number of its own periods before or after
  // the gap (give or take the stretch's 2% steps).
  const auto periods_back = [&](const BorrowedSpan& span, double period) {
    const double back = static_cast<double>(first - 1 - span.source_left) / period;
    return std::fabs(back - std::round(back));
  };
  EXPECT_LT(periods_back(spans[0], 100), 0.03);
  EXPECT_LT(periods_back(spans[1], 60), 0.03);

  const double by_whole_body = mean_angle(fill_gaps(take, &manifold, whole_body, kRate), truth, first, last);
  const MotionFrames filled = fill_gaps(take, &manifold, by_parts, kRate);
  const double by_part = mean_angle(filled, truth, first, last);
  std::printf("mean angle from the motion: whole body %.4f rad, by parts %.4f\n", by_whole_body, by_part);
  // Within the stretch's steps (3 degrees; 0.039 rad as measured), where the
  // whole body's fill is another motion (1.37 rad).
  EXPECT_LT(by_part, 0.06);
  EXPECT_GT(by_whole_body, 10 * by_part);

  // The take path, streamed a few frames at a time, fills it the same way.
  TakeGapFiller filler(take.columns, by_parts, kRate);
  MotionFrames streamed;
  streamed.columns = take.columns;
  for (int64_t f = 0; f < frames; f += 7) {
    const int64_t count = std::min<int64_t>(7, frames - f);
    MotionFrames given, decoded;
    given.values.assign(take.frame(f), take.frame(f) + count * take.columns);
    decoded.values.assign(manifold.frame(f), manifold.frame(f) + count * take.columns);
    filler.push(given, decoded, streamed);
  }
  filler.finish(streamed);
  ASSERT_EQ(streamed.frame_count(), frames);
  for (int64_t f = first; f <= last; ++f) {
    for (int c = kRootTranslationValues; c < take.columns; ++c) {
      ASSERT_NEAR(streamed.frame(f)[c], filled.frame(f)[c], 1e-5) << "frame " << f << ", column " << c;
    }
  }
}

// Where one stretch of the whole body is like the gap's surroundings, it is
// taken for every joint, so the arms stay in step with the legs, and the
// parts are not searched: the fill is the whole-body fill, value for value.
TEST(BodyPartBorrowing, AStretchOfTheWholeBodyLikeEnoughIsTakenWhole) {
  const int64_t frames = 600, first = 300, last = 374;
  MotionFrames take;
  take.values.resize(static_cast<size_t>(frames * take.columns));
  for (int64_t f = 0; f < frames; ++f) {  // every joint at the legs' pace
    for (int c = kRootTranslationValues; c < take.columns; ++c) {
      take.frame(f)[c] = static_cast<float>(0.6 * std::sin(2 * M_PI * static_cast<double>(f) / 100.0 + 0.7 * c));
    }
  }
  MotionFrames manifold = take;
  for (float& v : manifold.values) v = -v;
  for (int j = 0; j < 32; ++j) make_missing(take, j, first, last);
  GapFillOptions whole_body, by_parts;
  by_parts.borrow.parts = body_parts(Skeleton::h36m());
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(take, kRate, by_parts.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 1u);
  EXPECT_TRUE(spans[0].used) << spans[0].cost;
  EXPECT_EQ(spans[0].part, -1);
  const MotionFrames a = fill_gaps(take, &manifold, whole_body, kRate);
  const MotionFrames b = fill_gaps(take, &manifold, by_parts, kRate);
  ASSERT_EQ(a.values, b.values);
}

}  // namespace
}  // namespace mm
