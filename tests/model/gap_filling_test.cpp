// Gaps in a take filled by denoise with keep_observed (take_processor.h,
// gap_interpolation.h): on real S5 takes and the shipped model, the fill
// meets the recording at the gap's borders, is no worse than interpolation
// on short gaps of a few joints, and the take path, which hands a take out
// in pieces, fills exactly as the whole-take fill does.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <vector>

#include "format/foot_contacts.h"
#include "format/motion_text.h"
#include "model/borrowed_motion.h"
#include "model/default_model.h"
#include "model/gap_code_fit.h"
#include "model/gap_interpolation.h"
#include "model/motion_manifold.h"
#include "model/take_processor.h"
#include "tests/common/shipped_model_suite.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

class GapFilling : public test::ShippedModelSuite {
 protected:
  // `seconds` of an S5 take from `from_seconds` into it, at 25 Hz (every second frame of the 50 Hz file).
  static MotionFrames s5_at_25(const std::string& name, double seconds, double from_seconds = 0) {
    const MotionFrames file = read_motion_text((test::h36m_dataset_dir() / "S5" / name).string());
    MotionFrames take;
    take.columns = file.columns;
    for (int64_t f = 2 * std::lround(from_seconds * 25); f < file.frame_count() && take.frame_count() < std::lround(seconds * 25);
         f += 2) {
      take.values.insert(take.values.end(), file.frame(f), file.frame(f) + file.columns);
    }
    return take;
  }
  static void make_missing(MotionFrames& take, const std::vector<int>& joints, int64_t first, int64_t last) {
    for (int64_t f = first; f <= last; ++f) {
      for (int j : joints) std::fill_n(take.frame(f) + 3 + 3 * j, 3, std::numeric_limits<float>::quiet_NaN());
    }
  }
  static TakeResult denoise(const MotionFrames& take, GapMethod method, bool keep_observed = true, int batch = 32,
                            const GapCodeFitOptions& fit = {},
                            std::array<double, 2> speed_gain = GapFillOptions{}.speed_gain_range) {
    TakeOptions o;
    o.gap_fill.speed_gain_range = speed_gain;
    o.gap_fit = fit;
    o.operation = TakeOperation::kDenoise;
    o.frame_rate = 25;
    o.at_model_rate = true;
    o.batch_windows = batch;
    o.denoise.keep_observed = keep_observed;
    o.gap_fill.method = method;
    return process_take(*model_, take, o);
  }
  // Positions (mm, root at the origin) of every frame, frame-major.
  static std::vector<Vec3> positions(const MotionFrames& m) {
    std::vector<Vec3> p;
    for (int64_t f = 0; f < m.frame_count(); ++f) {
      const auto pose = pose_positions(model_->skeleton(), m.frame(f));
      p.insert(p.end(), pose.begin(), pose.end());
    }
    return p;
  }
  static double mean_distance(const std::vector<Vec3>& a, int64_t fa, const std::vector<Vec3>& b, int64_t fb,
                              const std::vector<int>& joints) {
    const int n = model_->skeleton().joint_count();
    double sum = 0;
    for (int j : joints) {
      const Vec3& p = a[static_cast<size_t>(fa * n + j)];
      const Vec3& q = b[static_cast<size_t>(fb * n + j)];
      sum += std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
    }
    return sum / static_cast<double>(joints.size());
  }
  // The joints a rotation of `missing` moves: their descendants.
  static std::vector<int> moved_by(const std::vector<int>& missing) {
    const auto& joints = model_->skeleton().joints;
    std::vector<bool> moved(joints.size(), false), source(joints.size(), false);
    for (int j : missing) source[static_cast<size_t>(j)] = true;
    for (size_t j = 1; j < joints.size(); ++j) {
      const auto parent = static_cast<size_t>(joints[j].parent);
      moved[j] = source[parent] || moved[parent];
    }
    std::vector<int> result;
    for (size_t j = 0; j < joints.size(); ++j) {
      if (moved[j]) result.push_back(static_cast<int>(j));
    }
    return result;
  }
  // The fitted fill of a take with two fitted windows, the first before
  // frame 200, with a bound on the fit's error that `bound` picks from the
  // two windows' errors (2 Adam steps a fit from one round of the encoder).
  struct BoundedFit {
    std::vector<double> errors;       // each window's, in order
    std::vector<bool> lays_detail;    // each window's, under the bound
    MotionFrames whole, unbounded, interpolated;  // fill_gaps: bounded, unbounded, the cubic
    MotionFrames streamed;            // the take path's, bounded
  };
  static BoundedFit bounded_fit(const MotionFrames& gapped, double (*bound)(double, double)) {
    GapCodeFitOptions fit;
    fit.max_observed_error = std::numeric_limits<double>::infinity();
    fit.iterations = 2;
    fit.encoder_rounds = 1;
    const MotionFrames decoded = denoise(gapped, GapMethod::kMatched, false, 1).frames;
    std::vector<GapFitWindow> windows;
    const MotionFrames fitted =
        fit_gap_codes(*model_, gapped, decoded, DecoderKind::kRotation, fit, nullptr, &windows);
    BoundedFit result;
    if (windows.size() != 2) return result;
    result.errors = {windows[0].observed_error, windows[1].observed_error};
    fit.max_observed_error = bound(result.errors[0], result.errors[1]);
    const MotionFrames bounded =
        fit_gap_codes(*model_, gapped, decoded, DecoderKind::kRotation, fit, nullptr, &windows);
    for (const GapFitWindow& window : windows) result.lays_detail.push_back(window.lays_detail);
    GapFillOptions by_fit;
    by_fit.method = GapMethod::kFitted;
    GapFillOptions cubic;
    cubic.method = GapMethod::kCubic;
    result.whole = fill_gaps(gapped, &bounded, by_fit, 25);
    result.unbounded = fill_gaps(gapped, &fitted, by_fit, 25);
    result.interpolated = fill_gaps(gapped, nullptr, cubic, 25);
    result.streamed = denoise(gapped, GapMethod::kFitted, true, 1, fit).frames;
    return result;
  }

  // Checks each window's gaps: the unbounded fill where the window lays its
  // detail, the cubic where it does not, whole and streamed alike, the
  // observed values untouched. Returns the largest difference from the cubic
  // in the windows that lay their detail.
  static double expect_windows_filled(const MotionFrames& gapped, const BoundedFit& fit) {
    EXPECT_EQ(fit.streamed.values.size(), fit.whole.values.size());
    double laid = 0;
    for (int64_t f = 0; f < gapped.frame_count() && fit.streamed.values.size() == fit.whole.values.size(); ++f) {
      const bool lays_detail = fit.lays_detail[f < 200 ? 0 : 1];
      for (int c = 0; c < gapped.columns; ++c) {
        const float value = gapped.frame(f)[c];
        if (!std::isnan(value)) {
          EXPECT_EQ(fit.whole.frame(f)[c], value) << "frame " << f << " column " << c;
          EXPECT_EQ(fit.streamed.frame(f)[c], value) << "frame " << f << " column " << c;
          continue;
        }
        const MotionFrames& expected = lays_detail ? fit.unbounded : fit.interpolated;
        if (fit.whole.frame(f)[c] != expected.frame(f)[c] ||
            std::fabs(fit.streamed.frame(f)[c] - expected.frame(f)[c]) > (lays_detail ? 1e-4 : 1e-6)) {
          ADD_FAILURE() << "frame " << f << " column " << c << ": whole " << fit.whole.frame(f)[c] << ", streamed "
                        << fit.streamed.frame(f)[c] << ", expected " << expected.frame(f)[c];
          return laid;
        }
        if (lays_detail) laid = std::max(laid, static_cast<double>(std::fabs(fit.whole.frame(f)[c] - fit.interpolated.frame(f)[c])));
      }
    }
    return laid;
  }

};

// Measured (walking_1 at 25 Hz, the first 16 s, every joint missing for 1 s
// from 8 s): the take's median move is 18.5 mm/frame; the manifold's fill
// as it was jumped 72.4 mm (3.9x) into or out of the gap, the matched fill
// 14.5 mm (0.78x).
TEST_F(GapFilling, EveryJointMissingForOneSecondJoinsTheRecordingWithoutAJump) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 16);
  MotionFrames gapped = take;
  const int64_t first = 200, last = 224;
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, every, first, last);
  std::vector<int> moved;
  for (int j = 1; j < model_->skeleton().joint_count(); ++j) moved.push_back(j);

  const auto recorded = positions(take);
  std::vector<double> moves;
  for (int64_t f = 1; f < take.frame_count(); ++f) moves.push_back(mean_distance(recorded, f - 1, recorded, f, moved));
  std::nth_element(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(moves.size() / 2), moves.end());
  const double median = moves[moves.size() / 2];
  auto border_jump = [&](const MotionFrames& filled) {
    const auto p = positions(filled);
    return std::max(mean_distance(p, first - 1, p, first, moved), mean_distance(p, last, p, last + 1, moved));
  };
  const double before = border_jump(denoise(gapped, GapMethod::kManifold).frames);
  const double now = border_jump(denoise(gapped, GapMethod::kMatched).frames);
  std::printf("median move %.1f mm/frame; border jump: manifold %.1f, matched %.1f mm/frame\n", median, before, now);
  EXPECT_GT(before, 1.5 * median);  // what the issue reported
  EXPECT_LE(now, 1.5 * median);
}

// The case: greeting_2 with five joints (both knees, the left arm
// and forearm, the right forearm) missing for 0.5 s at three places.
// Measured: slerp 30.5 mm, the manifold's fill as it was 130.2, matched 17.4.
TEST_F(GapFilling, FiveJointsMissingForHalfASecondAreFilledNoWorseThanSlerp) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("greeting_2.txt", 30);
  MotionFrames gapped = take;
  const std::vector<int> joints = {2, 7, 17, 18, 26};
  const int64_t firsts[] = {150, 380, 610};
  for (int64_t first : firsts) make_missing(gapped, joints, first, first + 11);
  const auto moved = moved_by(joints);
  const auto recorded = positions(take);
  auto gap_error = [&](const MotionFrames& filled) {
    const auto p = positions(filled);
    double sum = 0;
    int n = 0;
    for (int64_t first : firsts) {
      for (int64_t f = first; f <= first + 11; ++f, ++n) sum += mean_distance(p, f, recorded, f, moved);
    }
    return sum / n;
  };
  GapFillOptions slerp;
  slerp.method = GapMethod::kSlerp;
  const double slerp_error = gap_error(fill_gaps(gapped, nullptr, slerp, 25));
  const double before = gap_error(denoise(gapped, GapMethod::kManifold).frames);
  const double now = gap_error(denoise(gapped, GapMethod::kMatched).frames);
  std::printf("gap MPJPE: slerp %.1f, manifold %.1f, matched %.1f mm\n", slerp_error, before, now);
  EXPECT_GT(before, 1.05 * slerp_error);  // what the issue reported
  EXPECT_LE(now, 1.05 * slerp_error);
}

// The take path hands its frames out a batch of one window at a time, and
// holds a gap until the frame after it has arrived (and, with the
// speed-matched gain, the second of recording after it, keeping the second
// before it): the result is the whole-take fill of the same model output,
// with and without the gain, a long gap over a window's hand-out included,
// and the observed values are returned as given.
TEST_F(GapFilling, TheTakePathFillsAsTheWholeTakeFillDoes) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 16);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, every, 60, 159);  // 4 s across the hand-outs of several windows
  make_missing(gapped, {17, 18}, 300, 312);
  make_missing(gapped, {26}, 0, 5);      // at the take's start: one border
  make_missing(gapped, {2}, 395, 399);   // at its end
  const MotionFrames decoded = denoise(gapped, GapMethod::kMatched, false, 1).frames;
  for (const std::array<double, 2> gain : {std::array<double, 2>{1.0, 1.0}, std::array<double, 2>{0.5, 2.0}}) {
    SCOPED_TRACE(gain[1]);
    const MotionFrames streamed = denoise(gapped, GapMethod::kMatched, true, 1, {}, gain).frames;
    GapFillOptions options;
    options.method = GapMethod::kMatched;
    options.speed_gain_range = gain;
    MotionFrames whole = fill_gaps(gapped, &decoded, options, 25);
    ASSERT_EQ(streamed.values.size(), whole.values.size());
    for (size_t i = 0; i < whole.values.size(); ++i) {
      ASSERT_TRUE(std::isfinite(streamed.values[i])) << i;
      if (!std::isnan(gapped.values[i])) {
        ASSERT_EQ(streamed.values[i], gapped.values[i]) << i;
      } else {
        ASSERT_NEAR(streamed.values[i], whole.values[i], 1e-5) << i;
      }
    }
  }
}

// The fitted fill (the default): the take path hands its frames out a
// batch of one window at a time and fits each gap's centred window once its
// frames have arrived, one window after another; the result is the
// benchmark's fitted fill of the whole take (fit_gap_codes on the decoded
// frames, all windows in one batch, then fill_gaps), a window joining two
// gaps and one clamped to the take's end included. With a bound of two
// windows the third gap gets the matched fill of the take's own windows,
// and the summary counts both. The fits take 2 Adam steps from one round of
// the encoder instead of 15 from four (what is compared is where and how
// the windows are fitted, not how well): 44 s, 21 s of CPU, at a load of 8
// on two cores. Measured: the filled values differ from the whole take's by
// at most 3.5e-6 rad (a batch of one window against three).
TEST_F(GapFilling, TheTakePathFitsGapsAsTheWholeTakeFitDoesUpToItsBound) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 16);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, {26}, 0, 5);                // too short to fit
  make_missing(gapped, every, 60, 109);            // window 1
  make_missing(gapped, {1, 2, 6, 7, 17}, 180, 204);
  make_missing(gapped, {26}, 220, 235);            // window 2, with the gap before it
  make_missing(gapped, {2}, 300, 304);             // too short to fit
  make_missing(gapped, every, 370, 389);           // window 3, at the take's end
  GapCodeFitOptions fit;
  fit.iterations = 2;
  fit.encoder_rounds = 1;
  const MotionFrames decoded = denoise(gapped, GapMethod::kMatched, false, 1).frames;
  GapFitCounts whole_counts;
  const MotionFrames fitted = fit_gap_codes(*model_, gapped, decoded, DecoderKind::kRotation, fit, &whole_counts);
  GapFillOptions by_fit;
  by_fit.method = GapMethod::kFitted;
  const MotionFrames whole = fill_gaps(gapped, &fitted, by_fit, 25);
  const MotionFrames matched = fill_gaps(gapped, &decoded, by_fit, 25);
  const TakeResult streamed = denoise(gapped, GapMethod::kFitted, true, 1, fit);
  fit.max_windows = 2;
  const TakeResult bounded = denoise(gapped, GapMethod::kFitted, true, 1, fit);
  EXPECT_EQ(whole_counts.windows_fitted, 3);
  EXPECT_EQ(whole_counts.gaps_fitted, 4);
  EXPECT_EQ(streamed.summary.gap_windows_fitted, 3);
  EXPECT_EQ(streamed.summary.gaps_fitted, 4);
  EXPECT_EQ(streamed.summary.gaps_over_fit_limit, 0);
  EXPECT_EQ(bounded.summary.gap_windows_fitted, 2);
  EXPECT_EQ(bounded.summary.gaps_fitted, 3);
  EXPECT_EQ(bounded.summary.gaps_over_fit_limit, 1);
  ASSERT_EQ(streamed.frames.values.size(), whole.values.size());
  ASSERT_EQ(bounded.frames.values.size(), whole.values.size());
  double largest = 0, fit_changed = 0;
  for (size_t i = 0; i < whole.values.size(); ++i) {
    ASSERT_TRUE(std::isfinite(streamed.frames.values[i])) << i;
    if (!std::isnan(gapped.values[i])) {
      ASSERT_EQ(streamed.frames.values[i], gapped.values[i]) << i;
      ASSERT_EQ(bounded.frames.values[i], gapped.values[i]) << i;
      continue;
    }
    largest = std::max(largest, static_cast<double>(std::fabs(streamed.frames.values[i] - whole.values[i])));
    fit_changed = std::max(fit_changed, static_cast<double>(std::fabs(whole.values[i] - matched.values[i])));
    ASSERT_NEAR(streamed.frames.values[i], whole.values[i], 1e-4) << "frame " << i / 99 << " column " << i % 99;
    // The bounded take: the first two windows' gaps fitted, the last matched.
    const bool last_window = static_cast<int64_t>(i / 99) >= 370;
    ASSERT_NEAR(bounded.frames.values[i], last_window ? matched.values[i] : whole.values[i], 1e-4)
        << "frame " << i / 99 << " column " << i % 99;
  }
  std::printf("largest difference from the whole-take fit %.2g rad; the fit moved the fill by up to %.2f rad\n",
              largest, fit_changed);
  EXPECT_GT(fit_changed, 0.05);  // the fit is not the matched fill under another name

  // The borrowed fill (the default) through the same path: the take's own
  // stretch where one is like a gap's surroundings (here the 2 s gap of
  // every joint: a walk repeats itself), the same fitted windows elsewhere
  // (the gaps shorter than 2 s); the whole-take fill of the same fitted
  // frames, searching the model's legs and upper body apart as the take
  // path does.
  GapFillOptions by_borrowing;
  by_borrowing.borrow.parts = body_parts(model_->skeleton());
  const MotionFrames whole_borrowed = fill_gaps(gapped, &fitted, by_borrowing, 25);
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(gapped, 25, by_borrowing.borrow, 0, &spans);
  const auto used = std::count_if(spans.begin(), spans.end(), [](const BorrowedSpan& s) { return s.used; });
  EXPECT_EQ(used, 1);  // the whole body's stretch: the parts are not searched
  GapCodeFitOptions unbounded = fit;
  unbounded.max_windows = GapCodeFitOptions{}.max_windows;
  const TakeResult borrowed = denoise(gapped, GapMethod::kBorrowed, true, 1, unbounded);
  ASSERT_EQ(borrowed.frames.values.size(), whole_borrowed.values.size());
  double borrowing_changed = 0;
  for (size_t i = 0; i < whole_borrowed.values.size(); ++i) {
    if (!std::isnan(gapped.values[i])) {
      ASSERT_EQ(borrowed.frames.values[i], gapped.values[i]) << i;
      continue;
    }
    borrowing_changed = std::max(borrowing_changed, static_cast<double>(std::fabs(whole_borrowed.values[i] - whole.values[i])));
    ASSERT_NEAR(borrowed.frames.values[i], whole_borrowed.values[i], 1e-4) << "frame " << i / 99 << " column " << i % 99;
  }
  EXPECT_GT(borrowing_changed, 0.05);  // some gap is not the fitted fill
}

// The take path searches the model's legs and upper body apart where no
// stretch of the whole body is like enough: every joint of walking_2
// missing for 2 s (25 Hz frames 605 to 654, a gap of the benchmark's first
// run) has no stretch of the whole body like enough, but one of the legs;
// DenoiseTake's default fill is the whole-take fill with the parts, not the
// one with the whole body alone.
TEST_F(GapFilling, TheTakePathBorrowsForTheLegsWhereTheWholeBodyFindsNothing) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_2.txt", 40);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, every, 605, 654);
  GapFillOptions by_parts, whole_body;
  by_parts.borrow.parts = body_parts(model_->skeleton());
  std::vector<BorrowedSpan> spans;
  borrow_take_motion(gapped, 25, by_parts.borrow, 0, &spans);
  ASSERT_EQ(spans.size(), 3u);
  for (const BorrowedSpan& span : spans) std::printf("part %d: cost %.4f%s\n", span.part, span.cost, span.used ? ", taken" : "");
  ASSERT_FALSE(spans[0].used);
  ASSERT_TRUE(spans[1].used);  // the legs
  GapCodeFitOptions fit;
  fit.iterations = 2;
  fit.encoder_rounds = 1;
  const MotionFrames decoded = denoise(gapped, GapMethod::kMatched, false, 1).frames;
  const MotionFrames fitted = fit_gap_codes(*model_, gapped, decoded, DecoderKind::kRotation, fit);
  const MotionFrames with_parts = fill_gaps(gapped, &fitted, by_parts, 25);
  const MotionFrames without = fill_gaps(gapped, &fitted, whole_body, 25);
  const TakeResult taken = denoise(gapped, GapMethod::kBorrowed, true, 1, fit);
  ASSERT_EQ(taken.frames.values.size(), with_parts.values.size());
  double parts_changed = 0;
  for (size_t i = 0; i < with_parts.values.size(); ++i) {
    if (!std::isnan(gapped.values[i])) continue;
    parts_changed = std::max(parts_changed, static_cast<double>(std::fabs(with_parts.values[i] - without.values[i])));
    ASSERT_NEAR(taken.frames.values[i], with_parts.values[i], 1e-4) << "frame " << i / 99 << " column " << i % 99;
  }
  EXPECT_GT(parts_changed, 0.05);  // the legs' stretch is not the fitted fill
}

// A fitted window whose code meets its observed values worse than
// GapCodeFitOptions::max_observed_error lays no detail: its gap is the
// cubic's fill, on the whole take and through the take path alike, while
// the window within the bound lays its fitted detail as without a bound.
TEST_F(GapFilling, AWindowFittedPastTheErrorBoundLaysOnlyTheCubic) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 16);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, every, 60, 109);   // 2 s, window 1
  make_missing(gapped, every, 300, 349);  // 2 s, window 2
  // The bound between the two: the worse window is past it.
  const BoundedFit fit = bounded_fit(gapped, [](double a, double b) { return (a + b) / 2; });
  ASSERT_EQ(fit.errors.size(), 2u);
  std::printf("the windows' errors on their observed values: %.4f and %.4f\n", fit.errors[0], fit.errors[1]);
  ASSERT_NE(fit.errors[0], fit.errors[1]);
  const bool first_over = fit.errors[0] > fit.errors[1];
  EXPECT_EQ(fit.lays_detail, (std::vector<bool>{!first_over, first_over}));
  EXPECT_GT(expect_windows_filled(gapped, fit), 0.05);  // the window within the bound is not the cubic
}

// The bound is for in-betweening only: a window of a gap of five joints
// lays its detail past any bound (there its error is mostly that of the
// joints observed through the gap), while an every-joint gap's window
// past it gets the cubic, on the whole take and through the take path.
TEST_F(GapFilling, TheFitErrorBoundLeavesAFewJointsGapsWindowLayingItsDetail) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 16);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  make_missing(gapped, {1, 7, 12, 17, 26}, 60, 109);  // 2 s of five joints, window 1
  make_missing(gapped, every, 300, 349);              // 2 s of every joint, window 2
  // Both windows past the bound.
  const BoundedFit fit = bounded_fit(gapped, [](double a, double b) { return std::min(a, b) / 2; });
  ASSERT_EQ(fit.errors.size(), 2u);
  EXPECT_EQ(fit.lays_detail, (std::vector<bool>{true, false}));
  EXPECT_GT(expect_windows_filled(gapped, fit), 0.05);  // the five joints' gap is not the cubic
}

// Between lone keyframes (one observed frame, the frames on both sides of
// it missing) the manifold's detail is laid nowhere: the fill is the cubic
// through the keyframes, which was nearer the recording (keyframes every
// 1 s: 60.6 mm against 77.1 with the detail). A gap of the same length
// between observed runs still gets the detail. The "manifold" here is the
// take itself a second later: any other motion would do.
// A joint lost for good in a streamed take, with the default fill: the take
// path answers the frames as they come, a window's latency and the 10 s
// bridge behind (tests/model/long_gaps_test.cpp has the filler alone).
// Before the bridge it answered the 98 frames before the gap and then
// nothing until the take ended.
TEST_F(GapFilling, AStreamedTakeWithAJointLostForGoodIsAnsweredAsItComes) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 60);
  make_missing(gapped, {5}, 100, gapped.frame_count() - 1);
  TakeOptions o;
  o.operation = TakeOperation::kDenoise;
  o.frame_rate = 25;
  o.at_model_rate = true;
  o.denoise.keep_observed = true;
  o.batch_windows = 1;  // a window run as soon as its frames are in
  int64_t answered = 0;
  TakeSink sink;
  sink.on_frames = [&](const MotionFrames& frames, const std::vector<float>&) { answered += frames.frame_count(); };
  TakeProcessor processor(*model_, o, sink);
  for (int64_t f = 0; f < gapped.frame_count(); f += 25) {
    processor.push(gapped.frame(f), std::min<int64_t>(25, gapped.frame_count() - f));
  }
  const int64_t before_the_end = answered;
  processor.finish();
  std::printf("answered %lld of %lld frames before the take ended\n", static_cast<long long>(before_the_end),
              static_cast<long long>(answered));
  EXPECT_EQ(answered, gapped.frame_count());
  EXPECT_GE(before_the_end, gapped.frame_count() - 250 - 2 * 150);
}

TEST_F(GapFilling, BetweenLoneKeyframesTheFillIsTheCubicAndElsewhereItLaysTheDetail) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 12);
  MotionFrames manifold = take;
  std::rotate(manifold.values.begin(), manifold.values.begin() + 25 * take.columns, manifold.values.end());
  std::vector<int> every_joint;
  for (int j = 0; j < (take.columns - 3) / 3; ++j) every_joint.push_back(j);
  MotionFrames keyframes = take;
  for (int64_t f = 0; f + 25 < take.frame_count(); f += 25) make_missing(keyframes, every_joint, f + 1, f + 24);
  MotionFrames one_gap = take;
  make_missing(one_gap, every_joint, 126, 149);  // the same 24 frames, 5 s observed before and 5 s after

  GapFillOptions fitted, cubic;
  fitted.method = GapMethod::kFitted;
  cubic.method = GapMethod::kCubic;
  const auto differs = [](const MotionFrames& a, const MotionFrames& b) {
    double largest = 0;
    for (size_t i = 0; i < a.values.size(); ++i) largest = std::max(largest, std::abs(double(a.values[i]) - b.values[i]));
    return largest;
  };
  EXPECT_EQ(differs(fill_gaps(keyframes, &manifold, fitted, 25), fill_gaps(keyframes, nullptr, cubic, 25)), 0.0);
  EXPECT_GT(differs(fill_gaps(one_gap, &manifold, fitted, 25), fill_gaps(one_gap, nullptr, cubic, 25)), 0.01);
}

// The fit a gap between lone keyframes would get is thrown away (the fill
// there is the cubic alone), so none is made: a take of one pose a second
// (S5 walking_1, 20 to 30 s, every joint missing in between) fits no
// window and is the cubic's fill exactly, while the same take with one
// second missing between observed runs fits that gap's window. Measured
// through the tool before the planner skipped them (the same keyframes at
// 50 Hz): 3 windows of 10 gaps fitted and thrown away, 40.0 to 47.5 s of
// user CPU, against 2.6 to 8.0 s with none (docs/RESULTS.md, "Keyframes and
// transitions"). The fits take 2 Adam steps from one round of
// the encoder (what is pinned down is which gaps are fitted).
TEST_F(GapFilling, SparseKeyframesFitNoWindowAndAreTheCubicsFillWhileARealGapIsFitted) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25("walking_1.txt", 10.04, 20);  // 251 frames: the last a keyframe
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  MotionFrames keyed = take;
  for (int64_t f = 0; f + 25 < take.frame_count(); f += 25) make_missing(keyed, every, f + 1, f + 24);
  MotionFrames one_gap = take;
  make_missing(one_gap, every, 100, 124);
  GapCodeFitOptions fit;
  fit.iterations = 2;
  fit.encoder_rounds = 1;

  const TakeResult fitted = denoise(keyed, GapMethod::kFitted, true, 32, fit);
  const TakeResult cubic = denoise(keyed, GapMethod::kCubic, true, 32, fit);
  EXPECT_EQ(fitted.summary.gap_windows_fitted, 0);
  EXPECT_EQ(fitted.summary.gaps_fitted, 0);
  EXPECT_EQ(fitted.summary.gaps_over_fit_limit, 0);
  ASSERT_EQ(fitted.frames.values.size(), cubic.frames.values.size());
  for (size_t i = 0; i < cubic.frames.values.size(); ++i) {
    ASSERT_EQ(fitted.frames.values[i], cubic.frames.values[i]) << "frame " << i / 99 << " column " << i % 99;
  }
  const TakeResult real_gap = denoise(one_gap, GapMethod::kFitted, true, 32, fit);
  EXPECT_EQ(real_gap.summary.gap_windows_fitted, 1);
  EXPECT_EQ(real_gap.summary.gaps_fitted, 1);
}

// Keyframes first (one pose a second for 6 s), then two gaps of a second
// between observed runs, with room for two windows: the two real gaps get
// them, in the take path and in the whole-take fit alike, where the
// keyframes' windows used to take both and leave the real gaps to the
// matched fill.
TEST_F(GapFilling, KeyframesLeaveTheFitBudgetToTheRealGapsAfterThem) {
  MM_REQUIRE_H36M();
  MotionFrames gapped = s5_at_25("walking_1.txt", 20, 20);
  std::vector<int> every;
  for (int j = 0; j < model_->skeleton().joint_count(); ++j) every.push_back(j);
  for (int64_t f = 0; f < 150; f += 25) make_missing(gapped, every, f + 1, f + 24);  // keyframes at 0, 25, .. 150
  make_missing(gapped, every, 250, 274);
  make_missing(gapped, every, 400, 424);
  GapCodeFitOptions fit;
  fit.iterations = 2;
  fit.encoder_rounds = 1;
  fit.max_windows = 2;

  const TakeResult streamed = denoise(gapped, GapMethod::kFitted, true, 32, fit);
  EXPECT_EQ(streamed.summary.gap_windows_fitted, 2);
  EXPECT_EQ(streamed.summary.gaps_fitted, 2);
  EXPECT_EQ(streamed.summary.gaps_over_fit_limit, 0);
  GapFitCounts whole;
  fit_gap_codes(*model_, gapped, denoise(gapped, GapMethod::kMatched, false).frames, DecoderKind::kRotation, fit, &whole);
  EXPECT_EQ(whole.windows_fitted, 2);
  EXPECT_EQ(whole.gaps_fitted, 2);
  EXPECT_EQ(whole.gaps_over_limit, 0);
}

}  // namespace
}  // namespace mm
