// Table 1 in the reference implementation's units (model/paper_units.h):
// each definition on hand-made tensors with known answers, and the
// evaluation's paper-unit numbers against an independent computation on
// real S5 clips.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "format/input_error.h"
#include "format/motion_text.h"
#include "model/default_model.h"
#include "model/evaluation.h"
#include "model/latent_operations.h"
#include "model/paper_units.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

using test::small_h36m;

TEST(PaperUnits, AngleErrorIsTheMeanOfTheTripletNorms) {
  // 51 values = 17 triplets; an error of (3, 4, 0) on the sixth triplet and
  // none elsewhere is a norm of 5 on one triplet of 17. The evaluation's own
  // unit (one norm over all 51 values) would give 5.
  auto truth = at::randn({2, 3, 51});
  auto decoded = truth.clone();
  decoded[1][2][15] += 3.0;
  decoded[1][2][16] += 4.0;
  const auto error = paper_angle_error(decoded, truth);
  ASSERT_EQ(error.sizes(), (std::vector<int64_t>{2, 3}));
  EXPECT_NEAR(error[1][2].item<double>(), 5.0 / 17.0, 1e-6);
  EXPECT_EQ(error.sum().item<double>(), error[1][2].item<double>());
}

TEST(PaperUnits, TripletsAreConsecutiveValues) {
  // (3, 4) split over two triplets (values 2 and 3) is two norms of 3 and 4,
  // a mean of 7/2 over two triplets, not the 5 of one triplet.
  auto difference = at::zeros({6});
  difference[2] = 3.0;
  difference[3] = 4.0;
  EXPECT_NEAR(mean_triplet_norm(difference).item<double>(), 3.5, 1e-6);
}

TEST(PaperUnits, ValuesThatAreNotWholeTripletsAreRefusedByName) {
  try {
    mean_triplet_norm(at::zeros({4, 50}));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("50"), std::string::npos) << e.what();
  }
}

// Two joints over two frames: joint 0 never moves (its coordinates are
// dropped), joint 1 moves in x by 2 mm (std 1), in y by 0.002 mm (std 0.001,
// tiny but above 1e-4, so kept) and in z by 4 mm (std 2).
at::Tensor two_joint_frames() {
  return at::tensor({0.0, 0.0, 0.0, 1.0, 10.0, 0.0,  //
                     0.0, 0.0, 0.0, 3.0, 10.002, 4.0},
                    at::kDouble)
      .reshape({2, 6});
}

TEST(PaperUnits, StandardizationDropsConstantCoordinatesAndKeepsTinyOnes) {
  const auto s = CoordinateStandardization::fit(two_joint_frames());
  EXPECT_EQ(s.frames, 2);
  ASSERT_EQ(s.kept_count(), 3);
  for (int c = 0; c < 6; ++c) EXPECT_EQ(s.kept[c].item<bool>(), c >= 3) << "coordinate " << c;
  EXPECT_NEAR(s.mean[3].item<double>(), 2.0, 1e-12);
  EXPECT_NEAR(s.mean[4].item<double>(), 10.001, 1e-12);
  EXPECT_NEAR(s.stddev[3].item<double>(), 1.0, 1e-12);  // population std, as the reference's np.std
  EXPECT_NEAR(s.stddev[4].item<double>(), 0.001, 1e-9);
  EXPECT_NEAR(s.stddev[5].item<double>(), 2.0, 1e-12);
  const auto standardized = s.apply(at::tensor({7.0, 8.0, 9.0, 5.0, 10.003, 6.0}, at::kDouble));
  ASSERT_EQ(standardized.numel(), 6);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(standardized[c].item<double>(), 0.0) << "dropped coordinate " << c;
  EXPECT_NEAR(standardized[3].item<double>(), 3.0, 1e-9);
  EXPECT_NEAR(standardized[4].item<double>(), 2.0, 1e-6);
  EXPECT_NEAR(standardized[5].item<double>(), 2.0, 1e-9);
}

TEST(PaperUnits, PositionErrorIsTheTripletNormOfStandardizedCoordinates) {
  const auto s = CoordinateStandardization::fit(two_joint_frames());
  // (B=1, T=1, J=2, 3): joint 1 off by (3 std, 4 std, 0) = (3 mm, 0.004 mm, 0).
  auto truth = two_joint_frames()[0].reshape({1, 1, 2, 3});
  auto decoded = truth.clone();
  decoded[0][0][1][0] += 3.0;
  decoded[0][0][1][1] += 0.004;
  // Joint 0's coordinates are dropped, so an error there does not count, and
  // the mean runs over the one joint that is kept.
  decoded[0][0][0][2] += 100.0;
  const auto error = paper_position_error(s, decoded, truth);
  ASSERT_EQ(error.sizes(), (std::vector<int64_t>{1, 1}));
  EXPECT_NEAR(error.item<double>(), 5.0, 1e-6);
  // Two joints kept, the error on one of them: half the norm.
  auto moving_root = two_joint_frames();
  moving_root[1][0] = 2.0;  // joint 0's x now varies (std 1)
  EXPECT_NEAR(paper_position_error(CoordinateStandardization::fit(moving_root), decoded, truth).item<double>(), 2.5,
              1e-6);
}

TEST(PaperUnits, AJointMissingOneCoordinateKeepsItsOthersInItsTriplet) {
  auto frames = two_joint_frames();
  frames[1][5] = 0.0;  // joint 1's z no longer varies: dropped alone
  const auto s = CoordinateStandardization::fit(frames);
  EXPECT_EQ(s.kept_count(), 2);
  auto truth = frames[0].reshape({1, 2, 3});
  auto decoded = truth.clone();
  decoded[0][1][0] += 3.0;
  decoded[0][1][1] += 0.004;
  decoded[0][1][2] += 50.0;  // on the dropped coordinate: does not count
  EXPECT_NEAR(paper_position_error(s, decoded.unsqueeze(0), truth.unsqueeze(0)).item<double>(), 5.0, 1e-6);
}

TEST(PaperUnits, CoordinatesThatAreNotWholeJointsOrNeverVaryAreRefused) {
  EXPECT_THROW(CoordinateStandardization::fit(at::ones({4, 5})), InputError);
  EXPECT_THROW(CoordinateStandardization::fit(at::ones({4, 6})), InputError);
  EXPECT_THROW(CoordinateStandardization::fit(at::ones({0, 6})), InputError);
}

TEST(PaperUnits, H36mPositionStatisticsDropTheRootAndKeepEveryOtherJoint) {
  MM_REQUIRE_H36M();
  const auto& data = small_h36m();
  const auto model = [&] {
    auto config = test::tiny_config().model;
    return MotionManifold(config, data.normalization, Skeleton::h36m());
  }();
  const auto train = data.subset(data.train_subjects);
  const auto s = fit_position_standardization(model, train);
  int64_t frames = 0;
  for (const auto* sequence : train) frames += sequence->normalized.frame_count();
  EXPECT_EQ(s.frames, frames);
  // The root sits at the origin (the text layout has no height), so its 3
  // coordinates are dropped; every other joint keeps at least two.
  for (int c = 0; c < 3; ++c) EXPECT_FALSE(s.kept[c].item<bool>()) << "root coordinate " << c;
  for (int j = 1; j < 32; ++j) {
    EXPECT_GE(s.kept.narrow(0, 3 * j, 3).sum().item<int64_t>(), 2) << "joint " << j;
  }
  // One coordinate's statistics against a direct computation over frames:
  // the right foot's height (joint 3, y).
  double sum = 0, sum_squares = 0;
  for (const auto* sequence : train) {
    const auto normalized = at::from_blob(const_cast<float*>(sequence->normalized.values.data()),
                                          {sequence->normalized.frame_count(), sequence->normalized.columns});
    const auto y = model.positions_mm(normalized).select(-2, 3).select(-1, 1).to(at::kDouble);
    sum += y.sum().item<double>();
    sum_squares += y.pow(2).sum().item<double>();
  }
  const double mean = sum / frames;
  EXPECT_NEAR(s.mean[10].item<double>(), mean, 1e-6 * std::abs(mean));
  EXPECT_NEAR(s.stddev[10].item<double>(), std::sqrt(sum_squares / frames - mean * mean), 1e-3);
}

// The evaluation's paper-unit numbers, recomputed here from the clips it
// lists with plain loops over frames and triplets.
TEST(PaperUnits, EvaluationReportsTheTripletMeansOfItsOwnClips) {
  MM_REQUIRE_H36M();
  const auto& data = small_h36m();
  const auto model = [&] {
    auto config = test::tiny_config().model;
    auto m = MotionManifold(config, data.normalization, Skeleton::h36m());
    m.train(false);
    return m;
  }();
  const auto positions = fit_position_standardization(model, data.subset(data.train_subjects));
  EvaluationOptions options;
  options.clips = 3;
  options.corruption_probability = 0;
  const auto report = nlohmann::json::parse(
      evaluate_reconstruction(model, data.subset(data.test_subjects), options, &positions));
  const int frames = model.config().frames, dims = data.normalization.dims();
  std::vector<float> values;
  for (const auto& clip : report["test_clips"]) {
    for (const auto& s : data.sequences) {
      if (s.subject == clip["subject"] && s.action == clip["action"] && s.take == clip["take"] &&
          s.phase == clip["phase"]) {
        const float* first = s.normalized.frame(clip["start"].get<int64_t>());
        values.insert(values.end(), first, first + frames * dims);
      }
    }
  }
  ASSERT_EQ(values.size(), static_cast<size_t>(3 * frames * dims));
  const auto motion = at::from_blob(values.data(), {3, frames, dims}).clone();
  const auto decoded = model.decode(model.encode(motion), DecoderKind::kRotation).contiguous();
  const auto decoded_mm = model.positions_mm(decoded).to(at::kDouble).contiguous();
  const auto truth_mm = model.positions_mm(motion).to(at::kDouble).contiguous();
  const auto q_hat = decoded.accessor<float, 3>(), q = motion.accessor<float, 3>();
  const auto p_hat = decoded_mm.accessor<double, 4>(), p = truth_mm.accessor<double, 4>();
  const auto stddev = positions.stddev.contiguous();
  const auto std_mm = stddev.accessor<double, 1>();
  const int intervals = 5, per_interval = frames / intervals;
  std::vector<double> angle(intervals, 0.0), position(intervals, 0.0);
  for (int64_t n = 0; n < 3; ++n) {
    for (int64_t t = 0; t < frames; ++t) {
      double angle_sum = 0, position_sum = 0;
      for (int64_t k = 0; k < dims / 3; ++k) {
        double squares = 0;
        for (int64_t c = 3 * k; c < 3 * k + 3; ++c) {
          const double d = q_hat[n][t][c] - q[n][t][c];
          squares += d * d;
        }
        angle_sum += std::sqrt(squares);
      }
      int joints = 0;
      for (int64_t j = 0; j < 32; ++j) {
        double squares = 0;
        bool counted = false;
        for (int64_t a = 0; a < 3; ++a) {
          if (std_mm[3 * j + a] < 1e-4) continue;  // dropped
          const double d = (p_hat[n][t][j][a] - p[n][t][j][a]) / std_mm[3 * j + a];
          squares += d * d;
          counted = true;
        }
        position_sum += std::sqrt(squares);
        joints += counted;
      }
      angle[t / per_interval] += angle_sum / (dims / 3) / (3.0 * per_interval);
      position[t / per_interval] += position_sum / joints / (3.0 * per_interval);
    }
  }
  const auto& paper = report["decoders"]["rotation"]["paper_units"];
  for (int i = 0; i < intervals; ++i) {
    EXPECT_NEAR(paper["E_r"][i].get<double>(), angle[i], 1e-4 * angle[i]) << "interval " << i;
    EXPECT_NEAR(paper["E_p"][i].get<double>(), position[i], 1e-4 * position[i]) << "interval " << i;
  }
  EXPECT_EQ(paper["E_z"], report["decoders"]["rotation"]["E_z"]);
  EXPECT_EQ(report["paper_units"]["position_coordinates_kept"], positions.kept_count());
}

// On a real clip decoded by the shipped model the two angle units obey
// Cauchy-Schwarz: the mean of 17 triplet norms is at most the norm of all 51
// values over sqrt(17), and (triangle inequality) at least that norm over 17.
TEST(PaperUnits, TheTwoAngleUnitsObeyCauchySchwarzOnAClipOfTheShippedModel) {
  MM_REQUIRE_H36M();
  const MotionManifold model = MotionManifold::load(default_model_dir());
  const auto raw = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  MotionFrames clip = split_phases(raw, 2)[0];
  clip.values.resize(static_cast<size_t>(model.config().frames) * clip.columns);
  // The decoder's own poses (a decoded motion's root columns are its
  // generated path in world layout, not the pose the paper's units measure).
  const auto q_hat = model.decode(encode_motions(model, {clip}), DecoderKind::kRotation)[0].cpu();
  const auto q = model.to_normalized(at::from_blob(clip.values.data(), {clip.frame_count(), clip.columns}));
  ASSERT_EQ(q.size(-1), 51);
  const auto triplet_mean = paper_angle_error(q_hat, q);
  const auto whole_norm = (q_hat - q).norm(2, -1);
  EXPECT_TRUE((triplet_mean <= whole_norm / std::sqrt(17.0) + 1e-6).all().item<bool>());
  EXPECT_TRUE((triplet_mean >= whole_norm / 17.0 - 1e-6).all().item<bool>());
  // A real reconstruction is neither extreme: the error is spread over joints.
  const double ratio = (triplet_mean.mean() / whole_norm.mean()).item<double>();
  EXPECT_GT(ratio, 1.0 / 17.0 + 0.02);
  EXPECT_LT(ratio, 1.0 / std::sqrt(17.0));
}

}  // namespace
}  // namespace mm
