// Every number of the Table 1 evaluation (E_r, E_p, mpjpe_mm,
// angle_error_rad per interval, E_z) on a model small enough to work out by
// hand: networks whose outputs have a closed form, two 10-frame test
// sequences and 5 intervals of 2 frames. The expected values are computed
// here in double precision with plain loops and the reference kinematics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <torch/torch.h>
#include <vector>

#include "model/evaluation.h"
#include "model/motion_manifold.h"
#include "tests/model/reference_kinematics.h"

namespace mm {
namespace {

constexpr int kFrames = 10, kIntervals = 5, kDims = 7, kColumns = 99;
// Kept columns: joint 1 partly (x, y of its expmap), joint 2 partly (x, z),
// joint 17 whole. The model animates joints 1, 2 and 17; the others take
// their training mean, which still turns their children.
const std::vector<int> kKept{6, 7, 9, 11, 54, 55, 56};
const std::vector<int> kAnimated{1, 2, 17};
constexpr double kPositionScaleMm = 150.0;
// The encoder's new-gate input weights, its code layer, and the decoders' output biases.
const std::vector<double> kEncoderInput{0.9, -0.4, 0.3, 0.7, -0.8, 0.5, 0.2};
const std::vector<double> kCodeWeight{1.5, -2.0}, kCodeBias{0.1, -0.3};
const std::vector<double> kRotationBias{0.5, -0.8, 0.3, 1.1, -0.2, 0.6, -0.9};
const std::vector<double> kVelocityBias{0.08, -0.05, 0.1, -0.07, 0.04, 0.09, -0.06};

PoseNormalization hand_normalization() {
  PoseNormalization n;
  for (int c = 0; c < kColumns; ++c) {
    n.mean.push_back(static_cast<float>(0.2 * std::sin(0.9 * c)));
    n.stddev.push_back(static_cast<float>(0.3 + 0.1 * std::cos(c)));
  }
  n.kept_columns = kKept;
  n.position_scale_mm = kPositionScaleMm;
  return n;
}

// Networks with a closed form. Decoders: every weight zero, so the GRU's
// hidden state stays 0 and each step emits its output bias b; the rotation
// decoder gives b at every frame, the velocity decoder (b + its previous
// output) k * b at the k-th generated frame, i.e. (T - t) * b at frame t.
// Encoder: hidden size 1, only the new gate sees the input, so
// r = z = 1/2 and h_t = tanh(w . q_t) / 2 + h_{t-1} / 2, and z = W h_T + b.
MotionManifold hand_model() {
  ModelConfig config;
  config.pose_dims = kDims;
  config.hidden = 1;
  config.latent = 2;
  config.frames = kFrames;
  MotionManifold model(config, hand_normalization(), Skeleton::h36m());
  torch::NoGradGuard no_grad;
  auto zero_all = [](torch::nn::Module& m) {
    for (auto& p : m.parameters()) p.zero_();
  };
  zero_all(*model.encoder());
  auto encoder = model.encoder()->named_parameters();
  for (int d = 0; d < kDims; ++d) encoder["gru.weight_ih_l0"][2][d] = kEncoderInput[d];  // rows r, z, n
  for (int k = 0; k < 2; ++k) {
    encoder["to_code.weight"][k][0] = kCodeWeight[k];
    encoder["to_code.bias"][k] = kCodeBias[k];
  }
  const std::vector<std::pair<DecoderKind, const std::vector<double>*>> output_bias{
      {DecoderKind::kRotation, &kRotationBias}, {DecoderKind::kVelocity, &kVelocityBias}};
  for (const auto& [kind, bias] : output_bias) {
    zero_all(*model.decoder(kind));
    auto decoder = model.decoder(kind)->named_parameters();
    for (int d = 0; d < kDims; ++d) decoder["to_pose.bias"][d] = (*bias)[d];
  }
  model.train(false);
  return model;
}

using Clip = std::vector<std::vector<double>>;  // [frame][dim], normalised

Clip test_clip(int which) {
  Clip clip(kFrames, std::vector<double>(kDims));
  for (int t = 0; t < kFrames; ++t) {
    for (int d = 0; d < kDims; ++d) clip[t][d] = 0.9 * std::sin(0.45 * t + 1.3 * d + 2.0 * which) + 0.2 * which;
  }
  return clip;
}

PreparedSequence as_sequence(const Clip& clip, const std::string& action) {
  PreparedSequence s;
  s.subject = "S5";
  s.action = action;
  s.normalized.columns = kDims;
  for (const auto& frame : clip) {
    for (double v : frame) s.normalized.values.push_back(static_cast<float>(v));
  }
  return s;
}

Clip decoded(DecoderKind kind) {
  Clip clip(kFrames, std::vector<double>(kDims));
  for (int t = 0; t < kFrames; ++t) {
    for (int d = 0; d < kDims; ++d) {
      clip[t][d] = kind == DecoderKind::kRotation ? kRotationBias[d] : (kFrames - t) * kVelocityBias[d];
    }
  }
  return clip;
}

// The raw frame a model sees: root translation 0, kept columns
// x * std + mean, every other column its mean.
std::vector<double> raw_frame(const std::vector<double>& normalized) {
  const PoseNormalization n = hand_normalization();
  std::vector<double> raw(kColumns);
  for (int c = 0; c < kColumns; ++c) raw[c] = c < 3 ? 0.0 : n.mean[c];
  for (int d = 0; d < kDims; ++d) raw[kKept[d]] = normalized[d] * n.stddev[kKept[d]] + n.mean[kKept[d]];
  return raw;
}

std::vector<double> code_of(const Clip& clip) {
  double h = 0.0;
  for (const auto& q : clip) {
    double input = 0.0;
    for (int d = 0; d < kDims; ++d) input += kEncoderInput[d] * static_cast<float>(q[d]);
    h = 0.5 * std::tanh(input) + 0.5 * h;
  }
  return {kCodeWeight[0] * h + kCodeBias[0], kCodeWeight[1] * h + kCodeBias[1]};
}

struct Expected {
  std::vector<double> e_r, e_p, mpjpe_mm, angle_rad;
  double e_z = 0;
};

// The numbers for one decoder over the listed clips, by the definitions of evaluation.h.
Expected expected_numbers(const std::vector<Clip>& clips, DecoderKind kind) {
  const Skeleton skeleton = Skeleton::h36m();
  const Clip output = decoded(kind);
  Expected e;
  e.e_r.assign(kIntervals, 0.0);
  e.e_p.assign(kIntervals, 0.0);
  e.mpjpe_mm.assign(kIntervals, 0.0);
  e.angle_rad.assign(kIntervals, 0.0);
  const int per_interval = kFrames / kIntervals;
  const double frames_per_interval = static_cast<double>(clips.size()) * per_interval;
  for (const auto& truth : clips) {
    for (int t = 0; t < kFrames; ++t) {
      const int k = t / per_interval;
      double pose = 0.0;
      for (int d = 0; d < kDims; ++d) pose += std::pow(output[t][d] - static_cast<float>(truth[t][d]), 2);
      e.e_r[k] += std::sqrt(pose) / frames_per_interval;

      std::vector<double> truth_frame(truth[t].size());
      for (size_t d = 0; d < truth_frame.size(); ++d) truth_frame[d] = static_cast<float>(truth[t][d]);
      const auto raw_out = raw_frame(output[t]), raw_truth = raw_frame(truth_frame);
      const auto p_out = test::reference_positions(skeleton, raw_out);
      const auto p_truth = test::reference_positions(skeleton, raw_truth);
      double all_joints = 0.0, per_joint = 0.0;
      for (int j = 0; j < skeleton.joint_count(); ++j) {
        double squared = 0.0;
        for (int i = 0; i < 3; ++i) squared += std::pow(p_out[j][i] - p_truth[j][i], 2);
        all_joints += squared;
        per_joint += std::sqrt(squared);
      }
      e.e_p[k] += std::sqrt(all_joints) / kPositionScaleMm / frames_per_interval;
      e.mpjpe_mm[k] += per_joint / skeleton.joint_count() / frames_per_interval;

      for (int j : kAnimated) {
        auto rotation = [j](const std::vector<double>& raw) {
          return test::reference_rotation({raw[3 + 3 * j], raw[4 + 3 * j], raw[5 + 3 * j]});
        };
        e.angle_rad[k] += test::reference_angle_between(rotation(raw_out), rotation(raw_truth)) /
                          kAnimated.size() / frames_per_interval;
      }
    }
    const auto z = code_of(truth), z_hat = code_of(output);
    for (int i = 0; i < 2; ++i) e.e_z += std::abs(z_hat[i] - z[i]) / (2.0 * clips.size());
  }
  return e;
}

void expect_close(const std::vector<double>& actual, const std::vector<double>& expected, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  for (size_t k = 0; k < expected.size(); ++k) {
    EXPECT_NEAR(actual[k], expected[k], 1e-4 * std::abs(expected[k]) + 1e-7) << what << " interval " << k;
  }
}

// The evaluation of the hand model on six clips drawn (seed 3) from the two
// test sequences, without the denoising experiment (none of these numbers).
nlohmann::json evaluate_hand_model(const std::vector<Clip>& sequences) {
  const PreparedSequence first = as_sequence(sequences[0], "first"), second = as_sequence(sequences[1], "second");
  EvaluationOptions options;
  options.clips = 6;
  options.seed = 3;
  options.intervals = kIntervals;
  options.corruption_probability = 0;
  return nlohmann::json::parse(evaluate_reconstruction(hand_model(), {&first, &second}, options));
}

TEST(EvaluationNumbers, EveryTable1NumberMatchesTheHandComputedValueOfEachDecoder) {
  const std::vector<Clip> sequences{test_clip(0), test_clip(1)};
  const auto result = evaluate_hand_model(sequences);

  // The clips the evaluation drew (each sequence is exactly one clip long).
  std::vector<Clip> drawn;
  std::map<std::string, int> drawn_per_sequence;
  for (const auto& c : result["test_clips"]) {
    ASSERT_EQ(c["start"].get<int>(), 0);
    const std::string action = c["action"];
    drawn.push_back(action == "first" ? sequences[0] : sequences[1]);
    ++drawn_per_sequence[action];
  }
  ASSERT_EQ(drawn.size(), 6u);
  ASSERT_EQ(drawn_per_sequence.size(), 2u) << "the test needs both sequences drawn";
  EXPECT_DOUBLE_EQ(result["position_unit_mm"].get<double>(), kPositionScaleMm);

  // The evaluation runs in float32: 1e-4 relative. The nearest wrong
  // definitions are far off: a squared norm, a missing position scale
  // (x150), a norm over all joints for the MPJPE (x3 and more), an angle
  // averaged over all 32 joints (x3/32), intervals taken across clips
  // instead of frames, or a squared code difference.
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    const std::string name = decoder_name(kind);
    const auto& numbers = result["decoders"][name];
    const Expected e = expected_numbers(drawn, kind);
    expect_close(numbers["E_r"].get<std::vector<double>>(), e.e_r, name + " E_r");
    expect_close(numbers["E_p"].get<std::vector<double>>(), e.e_p, name + " E_p");
    expect_close(numbers["mpjpe_mm"].get<std::vector<double>>(), e.mpjpe_mm, name + " mpjpe_mm");
    expect_close(numbers["angle_error_rad"].get<std::vector<double>>(), e.angle_rad, name + " angle_error_rad");
    EXPECT_NEAR(numbers["E_z"].get<double>(), e.e_z, 1e-4 * e.e_z) << name << " E_z";
    EXPECT_GT(e.e_z, 0.01) << name;  // not trivially zero

    // The same numbers in generation order: the decoders run in reverse
    // time, so the clip's last interval comes first.
    const auto& generated = result["generation_order"]["decoders"][name];
    auto reversed = [](std::vector<double> v) {
      std::reverse(v.begin(), v.end());
      return v;
    };
    expect_close(generated["E_r"].get<std::vector<double>>(), reversed(e.e_r), name + " E_r, generation order");
    expect_close(generated["E_p"].get<std::vector<double>>(), reversed(e.e_p), name + " E_p, generation order");
    expect_close(generated["mpjpe_mm"].get<std::vector<double>>(), reversed(e.mpjpe_mm), name + " mpjpe, generation order");
    EXPECT_NEAR(generated["E_z"].get<double>(), e.e_z, 1e-4 * e.e_z) << name << " E_z, generation order";
  }
}

// Eq. 12's unbiased MMD with the inverse multiquadratic kernel, in plain loops.
double hand_mmd(const std::vector<std::vector<double>>& x, const std::vector<std::vector<double>>& y) {
  const double c = 2.0 * static_cast<double>(x[0].size());
  auto k = [c](const std::vector<double>& a, const std::vector<double>& b) {
    double squared = 0.0;
    for (size_t i = 0; i < a.size(); ++i) squared += (a[i] - b[i]) * (a[i] - b[i]);
    return c / (c + squared);
  };
  const double n = static_cast<double>(x.size());
  double within_x = 0, within_y = 0, across = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    for (size_t j = 0; j < x.size(); ++j) {
      if (i != j) within_x += k(x[i], x[j]) / (n * (n - 1));
      if (i != j) within_y += k(y[i], y[j]) / (n * (n - 1));
      across += k(x[i], y[j]) / (n * n);
    }
  }
  return within_x + within_y - 2 * across;
}

std::vector<std::vector<double>> rows(const at::Tensor& matrix) {
  std::vector<std::vector<double>> result;
  for (int64_t i = 0; i < matrix.size(0); ++i) {
    auto row = matrix[i].contiguous();
    result.emplace_back(row.data_ptr<double>(), row.data_ptr<double>() + row.numel());
  }
  return result;
}

TEST(EvaluationNumbers, PriorMatchIsTheMomentsAndMmdOfTheTestCodes) {
  const std::vector<Clip> sequences{test_clip(0), test_clip(1)};
  const auto result = evaluate_hand_model(sequences);
  std::vector<std::vector<double>> codes;
  for (const auto& c : result["test_clips"]) codes.push_back(code_of(c["action"] == "first" ? sequences[0] : sequences[1]));
  ASSERT_EQ(codes.size(), 6u);

  // Moments with the sample (n - 1) covariance.
  const double n = static_cast<double>(codes.size());
  std::vector<double> mean(2, 0.0);
  for (const auto& z : codes) for (int i = 0; i < 2; ++i) mean[i] += z[i] / n;
  double variance[2] = {0, 0}, covariance = 0;
  for (const auto& z : codes) {
    for (int i = 0; i < 2; ++i) variance[i] += (z[i] - mean[i]) * (z[i] - mean[i]) / (n - 1);
    covariance += (z[0] - mean[0]) * (z[1] - mean[1]) / (n - 1);
  }
  // The prior draws the evaluation makes: pairs of n x latent standard
  // normals from a generator seeded with the evaluation's seed.
  auto generator = at::detail::createCPUGenerator(result["seed"].get<uint64_t>());
  const int draws = result["prior_match"]["draws"];
  ASSERT_EQ(draws, 20);
  double codes_to_prior = 0, prior_to_prior = 0;
  for (int k = 0; k < draws; ++k) {
    const auto prior = rows(at::randn({6, 2}, generator, at::kDouble));
    const auto other = rows(at::randn({6, 2}, generator, at::kDouble));
    codes_to_prior += hand_mmd(codes, prior) / draws;
    prior_to_prior += hand_mmd(other, prior) / draws;
  }

  // A biased (n) covariance is 20% off at n = 6; a population of other draws
  // or the diagonal kept in the MMD moves it by more than 1e-4.
  const auto& match = result["prior_match"];
  auto near = [](double actual, double expected) { return std::abs(actual - expected) <= 1e-4 * std::abs(expected) + 1e-6; };
  EXPECT_TRUE(near(match["mean_norm"], std::hypot(mean[0], mean[1]))) << match.dump();
  EXPECT_TRUE(near(match["mean_abs_max"], std::max(std::abs(mean[0]), std::abs(mean[1])))) << match.dump();
  EXPECT_TRUE(near(match["variance_mean"], (variance[0] + variance[1]) / 2)) << match.dump();
  EXPECT_TRUE(near(match["variance_min"], std::min(variance[0], variance[1]))) << match.dump();
  EXPECT_TRUE(near(match["variance_max"], std::max(variance[0], variance[1]))) << match.dump();
  EXPECT_TRUE(near(match["covariance_off_diagonal_abs_mean"], std::abs(covariance))) << match.dump();
  EXPECT_TRUE(near(match["mmd_codes_to_prior"], codes_to_prior)) << match.dump() << " vs " << codes_to_prior;
  EXPECT_TRUE(near(match["mmd_prior_to_prior"], prior_to_prior)) << match.dump() << " vs " << prior_to_prior;
  EXPECT_GT(codes_to_prior, prior_to_prior);  // two codes repeated are far from N(0, I)
}

}  // namespace
}  // namespace mm
