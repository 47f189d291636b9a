// Resampling motions on rotations (format/expmap_slerp.h,
// format/motion_resampling.h): slerp's geometry, rate changes on real H3.6M
// takes, streaming in chunks, the root's running position, and refusals.
#include "format/motion_resampling.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/expmap_slerp.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/rotation_matrix.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

using ::testing::HasSubstr;

Vec3 vec(const float* v) { return {v[0], v[1], v[2]}; }

// Geodesic angle between the rotations of two exponential maps, radians.
double angle_between(const float* a, const float* b) {
  const Mat3 relative = multiply(transpose(expmap_to_matrix(vec(a))), expmap_to_matrix(vec(b)));
  const double trace = relative[0][0] + relative[1][1] + relative[2][2];
  return std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0));
}

// The largest angle between corresponding joints of two motions, radians.
double largest_joint_angle(const MotionFrames& a, const MotionFrames& b) {
  double largest = 0;
  for (int64_t f = 0; f < a.frame_count(); ++f) {
    for (int c = 3; c < a.columns; c += 3) largest = std::max(largest, angle_between(a.frame(f) + c, b.frame(f) + c));
  }
  return largest;
}

MotionFrames s5_at_25_hz(const std::string& file) {
  return split_phases(read_motion_text((test::h36m_dataset_dir() / "S5" / file).string()), 2)[0];
}

std::string refusal(const std::function<void()>& call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(ExpmapSlerp, EndsAreTheInputsExactly) {
  const float a[3] = {0.3f, -1.2f, 2.9f}, b[3] = {-3.5f, 0.1f, 0.2f};
  float out[3];
  slerp_expmap(a, b, 0.0, out);
  EXPECT_EQ(out[0], a[0]); EXPECT_EQ(out[1], a[1]); EXPECT_EQ(out[2], a[2]);
  slerp_expmap(a, b, 1.0, out);
  EXPECT_EQ(out[0], b[0]); EXPECT_EQ(out[1], b[1]); EXPECT_EQ(out[2], b[2]);
}

TEST(ExpmapSlerp, FollowsTheShortestArcAtConstantSpeed) {
  // On the geodesic, the angles to both ends add up to the whole and split
  // as t says; a per-component lerp of the maps leaves the arc (checked: it
  // misses by up to 0.3 rad on these pairs).
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(-2.5f, 2.5f);
  for (int pair = 0; pair < 200; ++pair) {
    const float a[3] = {value(random), value(random), value(random)};
    const float b[3] = {value(random), value(random), value(random)};
    const double whole = angle_between(a, b);
    for (double t : {0.1, 0.5, 0.83}) {
      float out[3];
      slerp_expmap(a, b, t, out);
      EXPECT_NEAR(angle_between(a, out), t * whole, 2e-5) << "pair " << pair << " t " << t;
      EXPECT_NEAR(angle_between(out, b), (1 - t) * whole, 2e-5) << "pair " << pair << " t " << t;
    }
  }
}

TEST(ExpmapSlerp, KeepsTheInputsRepresentationBeyondPi) {
  // 3.0 and 3.3 rad about one axis: 3.15 rad is the rotation halfway. Its
  // map of angle below pi (-3.133 about the axis) is the same rotation, but
  // a motion written with maps past pi would jump there.
  const float a[3] = {0, 0, 3.0f}, b[3] = {0, 0, 3.3f};
  float out[3];
  slerp_expmap(a, b, 0.5, out);
  EXPECT_NEAR(out[2], 3.15, 1e-5);
  EXPECT_NEAR(out[0], 0, 1e-6);
}

TEST(ExpmapSlerp, AMissingRotationStaysMissingWhereItWeighs) {
  const float a[3] = {0.1f, 0.2f, 0.3f}, missing[3] = {NAN, NAN, NAN};
  float out[3];
  slerp_expmap(a, missing, 0.5, out);
  EXPECT_TRUE(std::isnan(out[0]) && std::isnan(out[1]) && std::isnan(out[2]));
  slerp_expmap(a, missing, 0.0, out);
  EXPECT_EQ(out[2], 0.3f);
  slerp_expmap(missing, a, 1.0, out);
  EXPECT_EQ(out[1], 0.2f);
}

TEST(MotionResampling, FrameCountsCoverTheInputsDuration) {
  EXPECT_EQ(resampled_frame_count(300, 50, 25), 150);
  EXPECT_EQ(resampled_frame_count(301, 50, 25), 151);
  EXPECT_EQ(resampled_frame_count(150, 25, 120), 716);  // 149 x 4.8 + 1
  EXPECT_EQ(resampled_frame_count(721, 120, 25), 151);  // 6 s at 120 Hz: 6 s at 25 Hz
  EXPECT_EQ(resampled_frame_count(1, 120, 25), 1);
  EXPECT_EQ(resampled_frame_count(0, 120, 25), 0);
}

TEST(MotionResampling, HalvingTheRateKeepsEveryOtherFrameAndSumsTheRoot) {
  MM_REQUIRE_H36M();
  const MotionFrames take = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  const MotionFrames half = resample_motion(take, 50, 25);
  ASSERT_EQ(half.frame_count(), resampled_frame_count(take.frame_count(), 50, 25));
  for (int64_t k = 1; k < half.frame_count(); ++k) {
    for (int c = 3; c < take.columns; ++c) ASSERT_EQ(half.frame(k)[c], take.frame(2 * k)[c]) << k << " " << c;
    // The root's change over two input frames.
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(half.frame(k)[c], take.frame(2 * k - 1)[c] + take.frame(2 * k)[c], 1e-3);
  }
}

// Joints of a motion turning about fixed axes at constant speeds (geodesics,
// along which slerp is exact), over pi and back, at 25 Hz.
MotionFrames geodesic_motion(int frames) {
  MotionFrames motion;
  motion.columns = 12;
  const double axes[3][3] = {{0, 0, 1}, {0.6, 0.8, 0}, {0.48, -0.6, 0.64}};
  const double speeds[3] = {0.9, -0.35, 0.2};  // rad per 25 Hz frame
  for (int f = 0; f < frames; ++f) {
    motion.values.insert(motion.values.end(), {1.0f, 0.0f, -2.0f});
    for (int j = 0; j < 3; ++j) {
      const double angle = -2.0 + speeds[j] * f;
      for (int i = 0; i < 3; ++i) motion.values.push_back(static_cast<float>(axes[j][i] * angle));
    }
  }
  return motion;
}

TEST(MotionResampling, RoundTripsExactlyWhereTheRatesShareFrames) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25_hz("walking_1.txt");
  for (double rate : {50.0, 100.0, 125.0}) {
    const MotionFrames back = resample_motion(resample_motion(take, 25, rate), rate, 25);
    ASSERT_EQ(back.frame_count(), take.frame_count());
    for (int64_t f = 0; f < take.frame_count(); ++f) {
      for (int c = 3; c < take.columns; ++c) ASSERT_EQ(back.frame(f)[c], take.frame(f)[c]) << rate << " " << f;
    }
  }
}

TEST(MotionResampling, RoundTripThrough120HzIsWithin1e4RadiansAlongGeodesics) {
  const MotionFrames motion = geodesic_motion(150);
  MotionFrames back = resample_motion(resample_motion(motion, 25, 120), 120, 25, motion.frame_count());
  ASSERT_EQ(back.frame_count(), motion.frame_count());
  // The last 25 Hz frame lies past the 120 Hz grid (149 x 4.8 is not whole)
  // and is held from the one before: left out.
  MotionFrames compared = motion;
  compared.values.resize(compared.values.size() - compared.columns);
  back.values.resize(back.values.size() - back.columns);
  EXPECT_LT(largest_joint_angle(compared, back), 1e-4);
}

TEST(MotionResampling, RoundTripThrough120HzOnRealTakesCutsOnlyTheCornersBetweenFrames) {
  // A 25 Hz frame falls between two 120 Hz frames that lie on the arcs to
  // its two neighbours; the slerp between them cuts the corner at the frame,
  // by at most a tenth of the larger step around it (each 120 Hz frame is at
  // most 1/4.8 of a step away). H3.6M at 25 Hz turns a joint by up to 0.8 rad
  // a frame, so real takes come back within about a tenth of a radian at
  // worst (largest 0.051, 0.083 and 0.14 rad on these three; means 3e-4 to
  // 8e-4 rad), not within 1e-4 rad as along geodesics.
  MM_REQUIRE_H36M();
  for (const char* file : {"walking_1.txt", "eating_1.txt", "sittingdown_2.txt"}) {
    const MotionFrames take = s5_at_25_hz(file);
    const MotionFrames fast = resample_motion(take, 25, 120);
    ASSERT_EQ(fast.frame_count(), resampled_frame_count(take.frame_count(), 25, 120));
    const MotionFrames back = resample_motion(fast, 120, 25, take.frame_count());
    ASSERT_EQ(back.frame_count(), take.frame_count());
    double largest = 0, sum = 0;
    int64_t count = 0;
    for (int64_t f = 1; f + 1 < take.frame_count(); ++f) {
      for (int c = 3; c < take.columns; c += 3) {
        const double off = angle_between(take.frame(f) + c, back.frame(f) + c);
        const double step = std::max(angle_between(take.frame(f - 1) + c, take.frame(f) + c),
                                     angle_between(take.frame(f) + c, take.frame(f + 1) + c));
        ASSERT_LE(off, 0.105 * step + 1e-5) << file << " frame " << f << " column " << c;
        largest = std::max(largest, off);
        sum += off;
        ++count;
      }
    }
    std::printf("%s: 25 -> 120 -> 25 Hz, joint angle off: mean %.2g rad, largest %.2g rad\n", file, sum / count,
                largest);
    // The root's position (the running sum), interpolated linearly, cuts
    // its corners alike.
    double sum_in[3] = {0, 0, 0}, sum_back[3] = {0, 0, 0};
    for (int64_t f = 0; f + 1 < take.frame_count(); ++f) {
      for (int c = 0; c < 3; ++c) {
        sum_in[c] += take.frame(f)[c];
        sum_back[c] += back.frame(f)[c];
        const double step = std::max(std::fabs(take.frame(f)[c]), std::fabs(take.frame(f + 1)[c]));
        ASSERT_NEAR(sum_back[c], sum_in[c], 0.105 * step + 0.01) << file << " frame " << f;  // mm
      }
    }
  }
}

TEST(MotionResampling, UpsamplingPutsEachFrameOnTheArcBetweenItsNeighbours) {
  MM_REQUIRE_H36M();
  const MotionFrames take = s5_at_25_hz("walking_1.txt");
  const MotionFrames fast = resample_motion(take, 25, 120);
  for (int64_t k = 0; k + 1 < fast.frame_count(); k += 7) {
    const double x = k * 25.0 / 120.0;
    const int64_t i = static_cast<int64_t>(std::floor(x + 1e-9));
    if (i + 1 >= take.frame_count()) break;
    for (int c = 3; c < take.columns; c += 3) {
      const double whole = angle_between(take.frame(i) + c, take.frame(i + 1) + c);
      ASSERT_NEAR(angle_between(take.frame(i) + c, fast.frame(k) + c), (x - i) * whole, 1e-4) << k << " " << c;
    }
  }
}

TEST(MotionResampling, ChunksGiveWhatTheWholeTakeGives) {
  MM_REQUIRE_H36M();
  const MotionFrames take = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  const MotionFrames whole = resample_motion(take, 50, 120);
  MotionResampler resampler(take.columns, 50, 120);
  MotionFrames chunked;
  for (int64_t at = 0; at < take.frame_count();) {
    const int64_t n = std::min<int64_t>(take.frame_count() - at, 1 + at % 97);
    resampler.push(take.frame(at), n, chunked);
    at += n;
  }
  resampler.finish(chunked);
  EXPECT_EQ(chunked.values, whole.values);
}

TEST(MotionResampling, FinishHoldsTheLastFrameUpToARequestedLength) {
  MotionFrames take;
  take.columns = 6;
  take.values = {0, 0, 0, 0.1f, 0, 0, 5, 0, 0, 0.3f, 0, 0};  // 2 frames at 25 Hz
  const MotionFrames out = resample_motion(take, 25, 100, 7);
  ASSERT_EQ(out.frame_count(), 7);  // 5 reach the second frame's time, 2 held
  EXPECT_FLOAT_EQ(out.frame(4)[3], 0.3f);
  EXPECT_FLOAT_EQ(out.frame(6)[3], 0.3f);
  EXPECT_FLOAT_EQ(out.frame(6)[0], 0.0f);
  double root = 0;
  for (int64_t f = 0; f < 5; ++f) root += out.frame(f)[0];
  EXPECT_NEAR(root, 5.0, 1e-6);
}

TEST(MotionResampling, RatesOutsideTenToAThousandHertzAreRefusedByName) {
  for (double rate : {0.0, -50.0, 5.0, 2000.0, double(NAN), double(INFINITY)}) {
    const std::string message = refusal([&] { check_take_rate(rate, "frame_rate"); });
    EXPECT_THAT(message, HasSubstr("frame_rate: expected a frame rate of 10 to 1000 Hz")) << rate;
  }
  EXPECT_THAT(refusal([] { MotionResampler(99, 50, 0); }), HasSubstr("to_hz"));
  EXPECT_THAT(refusal([] { MotionResampler(100, 50, 25); }), HasSubstr("columns"));
}

}  // namespace
}  // namespace mm
