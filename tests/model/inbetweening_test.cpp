// In-betweening on the shipped model and real S5 takes: a long gap of every
// joint filled from a code fitted to what was observed around it
// (gap_code_fit.h) beats interpolation and keeps moving; sparse keyframes
// come back exactly; two clips joined by a generated transition
// (clip_transition.h) meet both clips exactly, and bad transition requests
// are refused naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "model/borrowed_motion.h"
#include "model/clip_transition.h"
#include "model/gap_code_fit.h"
#include "model/gap_interpolation.h"
#include "model/take_processor.h"
#include "tests/common/shipped_model_suite.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

class Inbetweening : public test::ShippedModelSuite {
 protected:
  // `seconds` of an S5 take from its 50 Hz frame `from`, at 25 Hz.
  static MotionFrames s5_at_25(const std::string& name, double seconds, int64_t from = 0) {
    const MotionFrames file = read_motion_text((test::h36m_dataset_dir() / "S5" / name).string());
    MotionFrames take;
    take.columns = file.columns;
    for (int64_t f = from; f < file.frame_count() && take.frame_count() < std::lround(seconds * 25); f += 2) {
      take.values.insert(take.values.end(), file.frame(f), file.frame(f) + file.columns);
    }
    return take;
  }
  static void make_missing(MotionFrames& take, int64_t first, int64_t last) {
    for (int64_t f = first; f <= last; ++f) {
      std::fill(take.frame(f) + kRootTranslationValues, take.frame(f) + take.columns,
                std::numeric_limits<float>::quiet_NaN());
    }
  }
  // The take path's decoded frames (denoise, the observed values not kept).
  static MotionFrames decoded(const MotionFrames& take) {
    TakeOptions o;
    o.operation = TakeOperation::kDenoise;
    o.frame_rate = 25;
    o.at_model_rate = true;
    return process_take(*model_, take, o).frames;
  }
  static std::vector<Vec3> pose(const float* frame) { return pose_positions(model_->skeleton(), frame); }
  // Mean over every joint but the root of the distance between two poses (mm).
  static double pose_distance(const float* a, const float* b) {
    const auto p = pose(a), q = pose(b);
    double sum = 0;
    for (size_t j = 1; j < p.size(); ++j) {
      sum += std::sqrt((p[j][0] - q[j][0]) * (p[j][0] - q[j][0]) + (p[j][1] - q[j][1]) * (p[j][1] - q[j][1]) +
                       (p[j][2] - q[j][2]) * (p[j][2] - q[j][2]));
    }
    return sum / static_cast<double>(p.size() - 1);
  }
  // MPJPE over frames [first, last] against the recording, and the speed
  // ratio: the movement over [first - 1, last + 1] over the recording's.
  struct Measure {
    double mpjpe = 0, speed = 0;
  };
  static Measure measure(const MotionFrames& filled, const MotionFrames& recorded, int64_t first, int64_t last) {
    Measure m;
    double moved = 0, moved_recorded = 0;
    for (int64_t f = first; f <= last; ++f) m.mpjpe += pose_distance(filled.frame(f), recorded.frame(f));
    for (int64_t f = first - 1; f <= last; ++f) {
      moved += pose_distance(filled.frame(f), filled.frame(f + 1));
      moved_recorded += pose_distance(recorded.frame(f), recorded.frame(f + 1));
    }
    m.mpjpe /= static_cast<double>(last - first + 1);
    m.speed = moved / moved_recorded;
    return m;
  }
};

// The issue's case: every joint of walking_1 missing for 2 s (its 50 Hz
// frames 1000 to 1099). Slerp between the border poses freezes (speed
// about 0.1); the default fill walks through the gap and is nearer the
// recording (no stretch of the whole body or of either part is like
// enough: it is the fitted fill).
TEST_F(Inbetweening, EveryJointMissingForTwoSecondsOfWalkingIsFilledBetterThanSlerpAndKeepsWalking) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 40);
  MotionFrames gapped = take;
  const int64_t first = 500, last = 549;
  make_missing(gapped, first, last);
  GapFillOptions slerp;
  slerp.method = GapMethod::kSlerp;
  const Measure by_slerp = measure(fill_gaps(gapped, nullptr, slerp, 25), take, first, last);
  const MotionFrames fitted = fit_gap_codes(*model_, gapped, decoded(gapped), DecoderKind::kRotation);
  // The default fill as the take path gives it (the legs and the upper body
  // searched apart where no stretch of the whole body is like enough).
  GapFillOptions options;
  options.borrow.parts = body_parts(model_->skeleton());
  const MotionFrames filled = fill_gaps(gapped, &fitted, options, 25);
  const Measure by_fit = measure(filled, take, first, last);
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(gapped, 25, options.borrow, 0, &spans);
  for (const BorrowedSpan& span : spans) std::printf("part %d: cost %.4f%s\n", span.part, span.cost, span.used ? ", taken" : "");
  std::printf("slerp %.1f mm at %.2fx the recording's speed; default %.1f mm at %.2fx\n", by_slerp.mpjpe, by_slerp.speed,
              by_fit.mpjpe, by_fit.speed);
  EXPECT_LT(by_fit.mpjpe, by_slerp.mpjpe);
  EXPECT_GE(by_fit.speed, 0.8);
  EXPECT_LE(by_fit.speed, 1.2);
}

// Every joint of walking_1 missing for 2 s where the walk's own steps
// elsewhere in the take are like its surroundings (25 Hz frames 1119 to
// 1168, a gap of the benchmark's long-gaps run): the default fill borrows
// them (borrowed_motion.h), stretched to the gap and laid over the cubic,
// without the model, nearer the recording than either interpolation and at
// the recording's speed; the observed frames are returned as given. The
// issue's gap above is not like enough (its best source costs 0.0208, past
// the bound of 0.02; taken anyway it would be 95.5 mm at 1.34x the speed
// against slerp's 74.8), so there the default is the fitted fill.
TEST_F(Inbetweening, EveryJointMissingForTwoSecondsOfWalkingBorrowsTheWalksOwnSteps) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 70);
  const GapFillOptions options;
  ASSERT_EQ(options.method, GapMethod::kBorrowed);
  MotionFrames issue_gap = take;
  make_missing(issue_gap, 500, 549);
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(issue_gap, 25, options.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 1u);
  EXPECT_TRUE(spans[0].found);
  EXPECT_FALSE(spans[0].used) << spans[0].cost;

  MotionFrames gapped = take;
  const int64_t first = 1119, last = 1168;
  make_missing(gapped, first, last);
  borrow_take_motion(gapped, 25, options.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 1u);
  const BorrowedSpan& source = spans[0];
  std::printf("source: frames %lld to %lld, cost %.4f\n", static_cast<long long>(source.source_left),
              static_cast<long long>(source.source_left + source.source_frames), source.cost);
  ASSERT_TRUE(source.used);
  // A whole stretch of the take, not the gap, within the search or the lookahead.
  EXPECT_TRUE(source.source_left + source.source_frames < first || source.source_left > last);
  EXPECT_GE(source.source_left, first - 1 - std::lround(options.borrow.search_seconds * 25));
  EXPECT_LE(source.source_left + source.source_frames, last + 1 + std::lround(options.borrow.lookahead_seconds * 25));
  // No model frames given: the gap is borrowed, it needs no fitted fill.
  const MotionFrames filled = fill_gaps(gapped, nullptr, options, 25);
  for (int64_t f = 0; f < take.frame_count(); ++f) {
    if (f >= first && f <= last) continue;
    for (int c = 0; c < take.columns; ++c) ASSERT_EQ(filled.frame(f)[c], take.frame(f)[c]) << f << " " << c;
  }
  GapFillOptions slerp, cubic;
  slerp.method = GapMethod::kSlerp;
  cubic.method = GapMethod::kCubic;
  const Measure by_slerp = measure(fill_gaps(gapped, nullptr, slerp, 25), take, first, last);
  const Measure by_cubic = measure(fill_gaps(gapped, nullptr, cubic, 25), take, first, last);
  const Measure borrowed = measure(filled, take, first, last);
  std::printf("slerp %.1f mm at %.2fx, cubic %.1f at %.2fx, borrowed %.1f at %.2fx\n", by_slerp.mpjpe, by_slerp.speed,
              by_cubic.mpjpe, by_cubic.speed, borrowed.mpjpe, borrowed.speed);
  EXPECT_LT(borrowed.mpjpe, std::min(by_slerp.mpjpe, by_cubic.mpjpe));
  EXPECT_GE(borrowed.speed, 0.8);
  EXPECT_LE(borrowed.speed, 1.2);
}

// Where nothing in the take is like a gap's surroundings (the bound at 0,
// or no observed stretch within the search), the borrowed fill is the
// fitted fill, value for value. The "fitted frames" here are the take a
// second later: any motion would do.
TEST_F(Inbetweening, AGapWithNoSourceLikeEnoughGetsTheFittedFill) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 20);
  MotionFrames fitted = take;
  std::rotate(fitted.values.begin(), fitted.values.begin() + 25 * take.columns, fitted.values.end());
  MotionFrames gapped = take;
  make_missing(gapped, 250, 299);
  GapFillOptions by_fit;
  by_fit.method = GapMethod::kFitted;
  const MotionFrames expected = fill_gaps(gapped, &fitted, by_fit, 25);
  GapFillOptions strict, blind;
  strict.borrow.max_cost = 0;
  blind.borrow.search_seconds = 0.1;
  blind.borrow.lookahead_seconds = 0;
  GapFillOptions any;
  for (const GapFillOptions* options : {&strict, &blind}) {
    const MotionFrames filled = fill_gaps(gapped, &fitted, *options, 25);
    ASSERT_EQ(filled.values, expected.values);
  }
  EXPECT_NE(fill_gaps(gapped, &fitted, any, 25).values, expected.values);  // with a source it differs
}

// One pose a second of walking_1, every other frame missing: the keyframes
// come back exactly and every frame between them is filled.
TEST_F(Inbetweening, KeyframesComeBackExactly) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 12);
  MotionFrames keyed = take;
  for (int64_t f = 0; f < take.frame_count(); ++f) {
    if (f % 25 != 0) make_missing(keyed, f, f);
  }
  const MotionFrames fitted = fit_gap_codes(*model_, keyed, decoded(keyed), DecoderKind::kRotation);
  const MotionFrames filled = fill_gaps(keyed, &fitted, GapFillOptions{}, 25);
  GapFillOptions cubic;
  cubic.method = GapMethod::kCubic;
  const MotionFrames by_cubic = fill_gaps(keyed, nullptr, cubic, 25);
  double error = 0, cubic_error = 0;
  int64_t between = 0;
  for (int64_t f = 0; f < take.frame_count(); ++f) {
    for (int c = 0; c < take.columns; ++c) ASSERT_TRUE(std::isfinite(filled.frame(f)[c])) << f << " " << c;
    if (f % 25 == 0) {
      for (int c = 0; c < take.columns; ++c) ASSERT_EQ(filled.frame(f)[c], take.frame(f)[c]) << f << " " << c;
    } else {
      error += pose_distance(filled.frame(f), take.frame(f));
      cubic_error += pose_distance(by_cubic.frame(f), take.frame(f));
      ++between;
    }
  }
  std::printf("between keyframes: fitted %.1f mm, cubic %.1f mm\n", error / between, cubic_error / between);
}

// walking_1 joined to sitting_1 by a 1 s transition: outside it the joined
// motion is the two clips as given; at its borders it moves no more than
// 1.5x the clips' median move from frame to frame.
TEST_F(Inbetweening, AGeneratedTransitionMeetsBothClipsExactly) {
  MM_REQUIRE_H36M();
  const MotionFrames a = s5_at_25("walking_1.txt", 5, 400), b = s5_at_25("sitting_1.txt", 5, 400);
  TransitionOptions options;
  options.seconds = 1.0;
  const JoinedClips joined = join_clips(*model_, a, b, options);
  const int64_t n = 25, na = a.frame_count();
  ASSERT_EQ(joined.frames.frame_count(), na + b.frame_count() - n);
  ASSERT_EQ(joined.transition_first, na - n);
  ASSERT_EQ(joined.transition_last, na - 1);
  for (int64_t f = 0; f < joined.frames.frame_count(); ++f) {
    const float* expected = f < na - n ? a.frame(f) : f >= na ? b.frame(f - na + n) : nullptr;
    for (int c = 0; c < a.columns; ++c) {
      ASSERT_TRUE(std::isfinite(joined.frames.frame(f)[c])) << f << " " << c;
      if (expected) ASSERT_EQ(joined.frames.frame(f)[c], expected[c]) << f << " " << c;
    }
  }
  std::vector<double> moves;
  for (const MotionFrames* clip : {&a, &b}) {
    for (int64_t f = 1; f < clip->frame_count(); ++f) moves.push_back(pose_distance(clip->frame(f - 1), clip->frame(f)));
  }
  std::nth_element(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(moves.size() / 2), moves.end());
  const double median = moves[moves.size() / 2];
  auto jump = [&](const JoinedClips& j) {
    return std::max(pose_distance(j.frames.frame(j.transition_first - 1), j.frames.frame(j.transition_first)),
                    pose_distance(j.frames.frame(j.transition_last), j.frames.frame(j.transition_last + 1)));
  };
  options.method = TransitionMethod::kCrossfade;
  const double crossfade_jump = jump(join_clips(*model_, a, b, options));
  std::printf("median move %.1f mm/frame; border jump: generated %.1f, crossfade %.1f\n", median, jump(joined),
              crossfade_jump);
  EXPECT_LE(jump(joined), 1.5 * median);
}

TEST_F(Inbetweening, TransitionRequestsOutOfRangeAreRefusedNamingTheField) {
  MM_REQUIRE_H36M();
  const MotionFrames a = s5_at_25("walking_1.txt", 5), b = s5_at_25("sitting_1.txt", 5);
  TransitionOptions options;
  options.seconds = 4.5;
  try {
    join_clips(*model_, a, b, options);
    FAIL() << "a 4.5 s transition was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("transition_seconds"), std::string::npos) << e.what();
  }
  options.seconds = 2.0;
  const MotionFrames short_a = s5_at_25("walking_1.txt", 2.5);
  try {
    join_clips(*model_, short_a, b, options);
    FAIL() << "a clip of 2.5 s was accepted for a 2 s transition";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("a: ", 0), 0u) << e.what();
  }
  EXPECT_THROW(parse_transition_method("blend"), InputError);
}

}  // namespace
}  // namespace mm
