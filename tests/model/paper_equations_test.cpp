// The equations the model implements, each against a value computed another
// way: Rodrigues' formula and forward kinematics against the plain-loop
// reference of reference_kinematics.h, the loss terms of Sec. 3.3 (Eq. 9-14,
// the angle, position and LSGAN terms in the frame-norm forms the shipped
// models were trained with; the forms as the paper writes them are pinned in
// losses_test.cpp, PaperLosses) against numbers worked out by hand on small
// tensors. Tolerances are set
// from the arithmetic's precision; each comment says how far off the
// nearest wrong equation would land.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "format/motion_text.h"
#include "model/forward_kinematics.h"
#include "model/losses.h"
#include "model/rotation.h"
#include "tests/common/test_environment.h"
#include "tests/model/reference_kinematics.h"

namespace mm {
namespace {

using test::Mat3;
using test::Vec3;

at::Tensor as_tensor(const Vec3& v) { return at::tensor({v[0], v[1], v[2]}, at::kDouble); }

Mat3 as_matrix(const at::Tensor& m) {
  Mat3 out;
  auto a = m.to(at::kDouble).contiguous();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[r][c] = a[r][c].item<double>();
  }
  return out;
}

double max_difference(const Mat3& a, const Mat3& b) {
  double worst = 0.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a[r][c] - b[r][c]));
  }
  return worst;
}

// Axes in every octant and angles from small to nearly pi.
std::vector<Vec3> general_expmaps() {
  std::vector<Vec3> out;
  const std::vector<Vec3> axes{{0.267, -0.534, 0.802}, {-0.9, 0.3, 0.316}, {0.577, 0.577, 0.577}, {0.1, 0.2, -0.975}};
  for (const auto& axis : axes) {
    const double norm = std::sqrt(test::dot(axis, axis));
    for (double angle : {0.01, 0.3, 1.0, 2.2, 3.1}) {
      out.push_back({axis[0] / norm * angle, axis[1] / norm * angle, axis[2] / norm * angle});
    }
  }
  return out;
}

// --- Rodrigues' formula (model/rotation.*) ---------------------------------

TEST(PaperEquations, RodriguesMatchesTheRowVectorRotationOfTheSkeletonConvention) {
  // Double precision on both sides: agreement to 1e-12. The transposed
  // matrix (the rotation the other way) is off by 2 sin(angle) * |axis
  // component|, at least 1e-3 for every vector here.
  for (const auto& w : general_expmaps()) {
    const Mat3 model = as_matrix(expmap_to_rotation_matrix(as_tensor(w)));
    EXPECT_LT(max_difference(model, test::reference_rotation(w)), 1e-12) << w[0] << " " << w[1] << " " << w[2];
  }
}

TEST(PaperEquations, QuarterTurnsMoveTheAxesAsTheSkeletonConventionSays) {
  // Worked by hand from v' = v . R: about z, x -> -y and y -> x; about x,
  // y -> -z; about y, x -> z. The column-vector convention gives the
  // opposite signs.
  struct Case {
    Vec3 expmap, v, expected;
  };
  const double q = M_PI / 2;
  for (const auto& c : std::vector<Case>{{{0, 0, q}, {1, 0, 0}, {0, -1, 0}},
                                         {{0, 0, q}, {0, 1, 0}, {1, 0, 0}},
                                         {{q, 0, 0}, {0, 1, 0}, {0, 0, -1}},
                                         {{0, q, 0}, {1, 0, 0}, {0, 0, 1}}}) {
    for (auto type : {at::kFloat, at::kDouble}) {
      auto r = expmap_to_rotation_matrix(as_tensor(c.expmap).to(type));
      auto moved = at::matmul(as_tensor(c.v).to(type).view({1, 3}), r).view({3}).to(at::kDouble);
      EXPECT_TRUE(at::allclose(moved, as_tensor(c.expected), 0.0, 1e-6)) << moved;
    }
  }
}

TEST(PaperEquations, RodriguesSmallAngleSeriesAgreesWithTheExactRotation) {
  // Below 1e-3 rad the model uses the Taylor series of sin(t)/t and
  // (1 - cos t)/t^2. Its truncation error is below 1e-14 here; a wrong sign
  // or coefficient of the t^2 term of sin(t)/t moves R by t^3/3 > 3e-11
  // at t = 5e-4, and dropping the (1 - cos t)/t^2 term by t^2/2 > 1e-7.
  for (double angle : {5e-4, 9.9e-4, 1.01e-3}) {
    const Vec3 w{0.48 * angle, -0.6 * angle, 0.64 * angle};  // unit axis (0.48, -0.6, 0.64)
    const Mat3 model = as_matrix(expmap_to_rotation_matrix(as_tensor(w)));
    EXPECT_LT(max_difference(model, test::reference_rotation(w)), 1e-14) << angle;
  }
}

TEST(PaperEquations, MatrixToExpmapInvertsTheReferenceRotation) {
  // Double precision: 1e-9 rad covers acos near its ends. The wrong sign of
  // the skew part gives -w, off by 2|w| >= 0.02.
  for (const auto& w : general_expmaps()) {
    const Mat3 r = test::reference_rotation(w);
    auto matrix = at::empty({3, 3}, at::kDouble);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) matrix[i][j] = r[i][j];
    }
    EXPECT_TRUE(at::allclose(rotation_matrix_to_expmap(matrix), as_tensor(w), 0.0, 1e-9)) << w[0] << " " << w[1];
  }
}

TEST(PaperEquations, AngleBetweenIsTheGeodesicDistanceOfTwoGeneralRotations) {
  // Non-coaxial pairs: the angle of A . B (instead of A . B^T) or of a
  // wrong trace differs by tenths of a radian; agreement here is 1e-9.
  const auto expmaps = general_expmaps();
  for (size_t i = 0; i + 7 < expmaps.size(); ++i) {
    const auto &a = expmaps[i], &b = expmaps[i + 7];
    const double model = rotation_angle_between(expmap_to_rotation_matrix(as_tensor(a)),
                                                expmap_to_rotation_matrix(as_tensor(b)))
                             .item<double>();
    const double reference = test::reference_angle_between(test::reference_rotation(a), test::reference_rotation(b));
    EXPECT_NEAR(model, reference, 1e-9) << i;
    EXPECT_GT(reference, 1e-3) << i;  // the pair is not degenerate
  }
}

// --- Forward kinematics (model/forward_kinematics.*) ------------------------

std::vector<double> rest_frame() { return std::vector<double>(99, 0.0); }

void set_joint(std::vector<double>& frame, int joint, const Vec3& expmap) {
  for (int k = 0; k < 3; ++k) frame[3 + 3 * joint + k] = expmap[k];
}

at::Tensor as_frames(const std::vector<std::vector<double>>& frames) {
  auto out = at::empty({static_cast<int64_t>(frames.size()), 99}, at::kDouble);
  for (size_t i = 0; i < frames.size(); ++i) {
    for (int c = 0; c < 99; ++c) out[static_cast<int64_t>(i)][c] = frames[i][c];
  }
  return out;
}

// Worst distance in mm between the model's positions (frames, 32, 3) and the reference.
double worst_joint_distance_mm(const at::Tensor& positions, const std::vector<std::vector<double>>& frames) {
  const Skeleton skeleton = Skeleton::h36m();
  auto p = positions.to(at::kDouble).contiguous();
  double worst = 0.0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto reference = test::reference_positions(skeleton, frames[i]);
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      double squared = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double d = p[static_cast<int64_t>(i)][j][k].item<double>() - reference[j][k];
        squared += d * d;
      }
      worst = std::max(worst, std::sqrt(squared));
    }
  }
  return worst;
}

TEST(PaperEquations, FkMatchesAnIndependentRowVectorChainOnABentArm) {
  // LeftArm (17) a quarter turn about z, LeftForeArm (18) a quarter turn
  // about x. By hand, with v . R: the forearm bone (along y) turns to +x,
  // and the hand bone (along y) turns first to -z by the elbow and stays
  // there under the shoulder's turn about z. A transposed rotation sends
  // the forearm to -x; the world rotation multiplied the other way round
  // (R_parent . R_local) sends the hand bone to +x: both hundreds of mm off.
  std::vector<double> frame = rest_frame();
  set_joint(frame, 17, {0, 0, M_PI / 2});
  set_joint(frame, 18, {M_PI / 2, 0, 0});
  auto p = ForwardKinematics(Skeleton::h36m()).positions(as_frames({frame}))[0];

  const double shoulder_height = 0.1 + 233.383263 + 257.077681 + 151.034226;  // Spine, Spine1, LeftShoulder, LeftArm
  const std::vector<std::pair<int, Vec3>> expected{
      {17, {0, shoulder_height, 0}},
      {18, {278.882773, shoulder_height, 0}},               // elbow: forearm along +x
      {19, {278.882773, shoulder_height, -251.733451}},     // wrist: hand along -z
      {22, {278.882773, shoulder_height, -351.733639}},     // LeftWrist_End: 100.000188 further along -z
      {21, {278.882773 + 99.999627, shoulder_height, -251.733451}},  // thumb end: z . R_x = y, y . R_z = x
  };
  for (const auto& [joint, position] : expected) {
    // Double precision: the closed form holds to 1e-9 mm.
    EXPECT_TRUE(at::allclose(p[joint], as_tensor(position), 0.0, 1e-9)) << "joint " << joint << ": " << p[joint];
  }
  EXPECT_LT(worst_joint_distance_mm(p.unsqueeze(0), {frame}), 1e-9);
}

// Every joint rotated, by a different amount about a different axis, so that
// every link of every chain multiplies two non-trivial rotations.
std::vector<double> everything_rotated(double phase) {
  std::vector<double> frame = rest_frame();
  for (int j = 0; j < 32; ++j) {
    set_joint(frame, j, {0.6 * std::sin(1.3 * j + phase), 0.5 * std::cos(0.7 * j + 2 * phase) + 0.1,
                         0.4 * std::sin(2.1 * j + 0.5 + phase)});
  }
  for (int c = 0; c < 3; ++c) frame[c] = 1000.0 * (c + 1);  // root translation: ignored
  return frame;
}

TEST(PaperEquations, FkMatchesTheIndependentChainWithEveryJointRotated) {
  const std::vector<std::vector<double>> frames{everything_rotated(0.0), everything_rotated(1.0),
                                                everything_rotated(2.5)};
  ForwardKinematics fk(Skeleton::h36m());
  // Double: 1e-9 mm. Float (the training path): float32 rounding over a
  // chain of 8 products of ~1000 mm stays below 0.01 mm. Any transposed or
  // reordered rotation moves the end effectors by tens of mm at least.
  EXPECT_LT(worst_joint_distance_mm(fk.positions(as_frames(frames)), frames), 1e-9);
  EXPECT_LT(worst_joint_distance_mm(fk.positions(as_frames(frames).to(at::kFloat)), frames), 1e-2);
  // Leading batch dimensions are kept: (2, 3, 99) -> (2, 3, 32, 3), frame by frame the same.
  auto batched = fk.positions(as_frames(frames).unsqueeze(0).expand({2, 3, 99}));
  ASSERT_EQ(batched.sizes(), (std::vector<int64_t>{2, 3, 32, 3}));
  EXPECT_LT(worst_joint_distance_mm(batched[1], frames), 1e-9);
}

TEST(PaperEquations, FkMatchesTheIndependentChainOnRealS5Frames) {
  MM_REQUIRE_H36M();
  const auto motion = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  std::vector<std::vector<double>> frames;
  for (int64_t f = 0; f < motion.frame_count(); f += 97) {
    frames.emplace_back(motion.frame(f), motion.frame(f) + 99);
  }
  ASSERT_GT(frames.size(), 10u);
  EXPECT_LT(worst_joint_distance_mm(ForwardKinematics(Skeleton::h36m()).positions(as_frames(frames)), frames), 1e-9);
}

// --- Loss terms of Sec. 3.3 (model/losses.*) -------------------------------

at::Tensor tensor_of(const std::vector<float>& values, std::vector<int64_t> shape) {
  return at::tensor(values).reshape(shape);
}

TEST(PaperEquations, AngleLossIsTheMeanOverClipsAndFramesOfThePoseErrorNorm) {
  // Eq. 9 (frame-norm form), 2 clips x 2 frames x 3 values; the frame errors (3,4,0),
  // (1,2,-2), (0,0,0), (2,-3,6) have norms 5, 3, 0, 7: mean 3.75. The mean
  // absolute value gives 1.5, the squared norm 24.5, the sum 15.
  auto q = tensor_of({0.5f, -1, 2, 0, 0, 0, 1, 1, 1, -2, 0.25f, 3}, {2, 2, 3});
  auto error = tensor_of({3, 4, 0, 1, 2, -2, 0, 0, 0, 2, -3, 6}, {2, 2, 3});
  // 1e-5: float rounding and the 1e-6 that keeps the root of a perfect frame differentiable.
  EXPECT_NEAR(angle_loss(q + error, q).item<float>(), 3.75f, 1e-5);
}

TEST(PaperEquations, PositionLossIsTheMeanOfTheNormOverAllJointsOfAFrame) {
  // Eq. 10 (frame-norm form), 1 clip x 2 frames x 2 joints. Frame 1: joints off by (3,0,0)
  // and (0,4,0): norm over all joints 5 (a sum of joint norms gives 7,
  // their mean 3.5). Frame 2: (1,2,2) and (0,0,0): 3. Mean 4.
  auto p = at::zeros({1, 2, 2, 3});
  auto error = tensor_of({3, 0, 0, 0, 4, 0, 1, 2, 2, 0, 0, 0}, {1, 2, 2, 3});
  EXPECT_NEAR(position_loss(p + error, p).item<float>(), 4.0f, 1e-5);
}

TEST(PaperEquations, ManifoldLossIsTheMeanAbsoluteCodeDifference) {
  // Eq. 11: differences 0.5, -1.5, 0, 2, -0.25, 0.25 -> mean |.| 4.5 / 6 = 0.75
  // (signed mean 1/6, mean square 1.09).
  auto z = tensor_of({1, 2, 3, 4, 5, 6}, {2, 3});
  auto difference = tensor_of({0.5f, -1.5f, 0, 2, -0.25f, 0.25f}, {2, 3});
  EXPECT_NEAR(manifold_loss(z + difference, z).item<float>(), 0.75f, 1e-6);
}

TEST(PaperEquations, MmdOfTwoPointsPerSetIsMinusOneThirdByHand) {
  // Eq. 12, latent 1, sigma^2 = 1: C = 2 * 1 * 1 = 2, k(x, y) = 2 / (2 + (x - y)^2).
  // Codes {0, 2}, prior {0, 1}:
  //   within codes, i != j:  k(0,2) twice / (2 * 1)            = 1/3
  //   within prior, i != j:  k(0,1) twice / 2                  = 2/3
  //   across, all 4 pairs:   (1 + 2/3 + 1/3 + 2/3) / 4         = 2/3
  //   MMD = 1/3 + 2/3 - 2 * 2/3 = -1/3.
  // With C = latent * sigma^2 it is -0.4; with the diagonals kept, +1/6.
  auto codes = tensor_of({0, 2}, {2, 1});
  auto prior = tensor_of({0, 1}, {2, 1});
  EXPECT_NEAR(mmd_inverse_multiquadratic(codes, prior, 1.0).item<float>(), -1.0f / 3.0f, 1e-6);
}

TEST(PaperEquations, MmdMatchesThePlainSumsOfTheUnbiasedEstimator) {
  // 4 codes and 4 prior samples in 3 dimensions, sigma^2 = 0.5: C = 3.
  // The sums written out in double; float agrees to 1e-6, while a C of 1.5
  // or 6, a kept diagonal or a halved cross term moves the value by > 0.01.
  const std::vector<std::vector<double>> x{{0.5, -1.0, 0.2}, {1.5, 0.25, -0.7}, {-0.75, 0.5, 1.1}, {0.0, 0.3, -0.2}};
  const std::vector<std::vector<double>> y{{0.1, 0.2, 0.0}, {-1.0, -0.5, 0.4}, {0.8, -1.2, 0.3}, {0.2, 0.9, -1.4}};
  const double c = 2.0 * 3 * 0.5;
  auto k = [&](const std::vector<double>& a, const std::vector<double>& b) {
    double d = 0.0;
    for (int i = 0; i < 3; ++i) d += (a[i] - b[i]) * (a[i] - b[i]);
    return c / (c + d);
  };
  double within_x = 0.0, within_y = 0.0, across = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      if (i != j) within_x += k(x[i], x[j]);
      if (i != j) within_y += k(y[i], y[j]);
      across += k(x[i], y[j]);
    }
  }
  const double expected = within_x / 12 + within_y / 12 - 2 * across / 16;
  auto as_tensor_2d = [](const std::vector<std::vector<double>>& rows) {
    std::vector<float> flat;
    for (const auto& r : rows) flat.insert(flat.end(), r.begin(), r.end());
    return at::tensor(flat).reshape({4, 3});
  };
  EXPECT_NEAR(mmd_inverse_multiquadratic(as_tensor_2d(x), as_tensor_2d(y), 0.5).item<float>(), expected, 1e-6);
  EXPECT_GT(std::abs(expected), 0.01);
}

TEST(PaperEquations, LsganDiscriminatorLossHalvesTheMeanSquaredDistancesToItsTargets) {
  // Eq. 13 (half-mean form): real scores 0.2, 1.5, 0.9 (target 1): squares 0.64, 0.25, 0.01,
  // mean 0.3; generated 0.3, -0.4 (target 0): squares 0.09, 0.16, mean 0.125.
  // Loss 0.5 * 0.125 + 0.5 * 0.3 = 0.2125 (swapped targets give 0.8125).
  auto real = at::tensor({0.2f, 1.5f, 0.9f});
  auto fake = at::tensor({0.3f, -0.4f});
  EXPECT_NEAR(lsgan_discriminator_loss(real, fake).item<float>(), 0.2125f, 1e-6);
}

TEST(PaperEquations, LsganGeneratorLossHalvesTheMeanSquaredDistanceToOne) {
  // Eq. 14 (half-mean form): scores 0.3, -0.4, 2: squares to 1 of 0.49, 1.96, 1: mean 1.15, half 0.575.
  EXPECT_NEAR(lsgan_generator_loss(at::tensor({0.3f, -0.4f, 2.0f})).item<float>(), 0.575f, 1e-6);
}

}  // namespace
}  // namespace mm
