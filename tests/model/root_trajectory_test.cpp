// The root path of generated motion (root_trajectory.h) on the shipped
// default model and real S5 data: decoded walks travel as far as the
// recordings, closer to the recorded path than the baselines a user would
// try (no root motion; the first second's velocity held), and planting the
// feet removes skating that the generated path leaves.
#include <gtest/gtest.h>

#include <c10/core/InferenceMode.h>
#include <torch/nn/modules/conv.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/root_path.h"
#include "model/default_model.h"
#include "model/latent_operations.h"
#include "model/motion_manifold.h"
#include "model/root_trajectory.h"
#include "model/take_processor.h"
#include "model/trajectory_evaluation.h"
#include "model/trajectory_training.h"
#include "tests/common/shipped_model_suite.h"
#include "tests/common/test_environment.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

constexpr double kRate = 25.0;

// 150-frame clips of an S5 take at 25 Hz with the root's true change per
// frame, every `hop` frames, each clip's path starting at the origin, as
// recorded (root-change layout: what the model reads).
std::vector<MotionFrames> s5_clips(const std::string& take, int64_t hop, int64_t frames = 150) {
  const auto raw = read_motion_text((test::h36m_dataset_dir() / "S5" / take).string());
  const MotionFrames at_25_hz = split_phases_keeping_root_path(raw, 2)[0];
  std::vector<MotionFrames> clips;
  for (int64_t start = 0; start + frames <= at_25_hz.frame_count(); start += hop) {
    MotionFrames clip;
    clip.columns = at_25_hz.columns;
    clip.values.assign(at_25_hz.frame(start), at_25_hz.frame(start) + frames * at_25_hz.columns);
    clip.frame(0)[0] = clip.frame(0)[1] = clip.frame(0)[2] = 0.0f;
    clips.push_back(std::move(clip));
  }
  return clips;
}

// The recorded clips' root as a path in the world, levelled, on the floor:
// what a generated path is measured against.
std::vector<MotionFrames> in_the_world(std::vector<MotionFrames> clips) {
  for (auto& clip : clips) integrate_level_root_path(Skeleton::h36m(), clip, kRootRotationStepsPerFrame);
  return clips;
}

std::vector<MotionFrames> s5_walking_clips() {
  std::vector<MotionFrames> clips;
  for (const char* take : {"walking_1.txt", "walking_2.txt", "walkingdog_1.txt", "walkingtogether_1.txt"}) {
    for (auto& clip : s5_clips(take, 150)) clips.push_back(std::move(clip));
  }
  return clips;
}

// The length of the root's horizontal path (world layout).
double distance_travelled(const MotionFrames& motion) {
  double length = 0;
  for (int64_t f = 1; f < motion.frame_count(); ++f) length += std::hypot(motion.frame(f)[0], motion.frame(f)[2]);
  return length;
}

class RootTrajectoryTest : public test::ShippedModelSuite {
 protected:
  void SetUp() override {
    if (!test::has_h36m()) {
      if (test::missing_h36m_allowed()) GTEST_SKIP() << "H3.6M not extracted";
      FAIL() << "H3.6M not found at " << test::h36m_dataset_dir();
    }
  }
};

TEST_F(RootTrajectoryTest, TheShippedModelHasATrajectoryNetwork) {
  EXPECT_TRUE(model_->has_trajectory());
  EXPECT_NE(model_->trajectory_training_json().find("iterations"), std::string::npos);
}

TEST_F(RootTrajectoryTest, ADecodedWalkTravelsAsFarAsTheRecordedWindow) {
  const auto clips = s5_clips("walking_1.txt", 200);
  ASSERT_GE(clips.size(), 5u);
  const auto recorded = in_the_world(clips);
  const auto decoded = decode_codes(*model_, encode_motions(*model_, clips), model_->default_decoder());
  for (size_t i = 0; i < clips.size(); ++i) {
    const double truth = distance_travelled(recorded[i]), generated = distance_travelled(decoded[i]);
    EXPECT_GT(truth, 2000.0) << "clip " << i << " is a walk";
    EXPECT_NEAR(generated, truth, 0.25 * truth) << "clip " << i;
  }
}

// The network on the recorded poses (and their code) ends within 15% of
// the distance travelled, far nearer than either baseline; decoded from a
// clip's code, whose poses turn about half as much as the recording
// (docs/RESULTS.md), the path stays nearer the recording over the clip
// than either baseline.
TEST_F(RootTrajectoryTest, WalkingPathsBeatStandingStillAndTheHeldFirstSecond) {
  const auto clips = s5_walking_clips();
  ASSERT_GE(clips.size(), 20u);
  const auto recorded = in_the_world(clips);
  const auto codes = encode_motions(*model_, clips);
  const auto decoded = decode_codes(*model_, codes, model_->default_decoder());
  std::vector<MotionFrames> from_poses = clips;
  {
    c10::InferenceMode inference;
    auto raw = at::empty({static_cast<int64_t>(clips.size()), 150, kH36mColumns});
    for (size_t i = 0; i < clips.size(); ++i) {
      std::memcpy(raw[static_cast<int64_t>(i)].data_ptr<float>(), clips[i].values.data(), clips[i].values.size() * sizeof(float));
    }
    write_generated_roots(*model_, model_->to_normalized(raw), codes, from_poses);
  }
  const PathErrors posed = compare_root_paths(recorded, from_poses, kRate);
  const PathErrors generated = compare_root_paths(recorded, decoded, kRate);
  const PathErrors standing = compare_root_paths(recorded, standing_roots(recorded), kRate);
  const PathErrors held = compare_root_paths(recorded, held_first_second_roots(recorded, kRate), kRate);
  std::printf("final displacement error: from the recorded poses %.0f mm (%.1f%% of %.0f mm), decoded %.0f, "
              "standing %.0f, held %.0f; path error %.0f, %.0f, %.0f, %.0f mm\n",
              posed.final_error_mm, 100 * posed.final_error_share, posed.distance_mm, generated.final_error_mm,
              standing.final_error_mm, held.final_error_mm, posed.path_error_mm, generated.path_error_mm,
              standing.path_error_mm, held.path_error_mm);
  EXPECT_LT(posed.final_error_share, 0.15);  // the target of docs/RESULTS.md
  EXPECT_LT(posed.final_error_mm, standing.final_error_mm);
  EXPECT_LT(posed.final_error_mm, held.final_error_mm);
  EXPECT_LT(generated.path_error_mm, standing.path_error_mm);
  EXPECT_LT(generated.path_error_mm, held.path_error_mm);
  ASSERT_TRUE(generated.heading_error_deg.has_value());
  EXPECT_FALSE(standing.heading_error_deg.has_value());
}

TEST_F(RootTrajectoryTest, RecordedWalkingSkatesRarelyAndPlantingLowersTheReconstructionsSkating) {
  const auto clips = s5_walking_clips();
  const SkatingCount recorded = total_skating(model_->skeleton(), in_the_world(clips), kRate);
  // The recorded feet: in a few percent of frames a foot on the floor moves
  // (a heel strike or a toe-off at 25 Hz), never in none.
  EXPECT_GT(recorded.ratio(), 0.0);
  EXPECT_LT(recorded.ratio(), 0.10);
  auto decoded = decode_codes(*model_, encode_motions(*model_, clips), model_->default_decoder());
  const SkatingCount before = total_skating(model_->skeleton(), decoded, kRate);
  for (auto& motion : decoded) plant_feet(model_->skeleton(), motion, kRate);
  const SkatingCount after = total_skating(model_->skeleton(), decoded, kRate);
  std::printf("skating ratio: recorded %.3f, decoded %.3f, decoded with feet planted %.3f\n", recorded.ratio(),
              before.ratio(), after.ratio());
  EXPECT_LT(after.ratio(), before.ratio());
  EXPECT_LT(after.ratio(), recorded.ratio() + 0.02);
}

// Samples stand on the floor y = 0 (the 5th percentile of the lowest
// foot's height), their lowest foot near it in most frames, hips up.
TEST_F(RootTrajectoryTest, GeneratedMotionStandsOnTheFloor) {
  const auto sampled = decode_codes(*model_, sample_codes(*model_, 4, 11), model_->default_decoder());
  const SkeletonFeet feet = find_feet(model_->skeleton());
  ASSERT_EQ(feet.names, (std::vector<std::string>{"RightFoot", "LeftFoot"}));
  for (const auto& motion : sampled) {
    const auto world = world_positions(model_->skeleton(), motion);
    EXPECT_NEAR(floor_height(model_->skeleton(), feet, world, motion.frame_count()), 0.0, 10.0);  // mm
    const int joints = model_->skeleton().joint_count();
    int64_t on_or_near = 0;
    for (int64_t f = 0; f < motion.frame_count(); ++f) {
      double lowest = 1e9;
      for (const auto& foot : feet.joints) {
        for (int j : foot) lowest = std::min(lowest, world[static_cast<size_t>(f * joints + j)][1]);
      }
      on_or_near += lowest > -30.0 && lowest < 60.0;
      ASSERT_GT(world[static_cast<size_t>(f * joints)][1], 300.0) << "frame " << f;  // the hips
    }
    // Integrated without settling, a sample's lowest foot was within this
    // band in as few as 40% of its frames.
    EXPECT_GT(on_or_near, motion.frame_count() * 7 / 10);
  }
}

TEST_F(RootTrajectoryTest, ATakeReconstructedWithAGeneratedRootTravelsLikeTheRecording) {
  const auto raw = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  MotionFrames take;
  take.columns = raw.columns;
  take.values.assign(raw.values.begin(), raw.values.begin() + 1000 * raw.columns);  // 20 s at 50 Hz
  TakeOptions options;
  options.frame_rate = 50;
  options.root = TakeRoot::kGenerated;
  const TakeResult generated = process_take(*model_, take, options);
  options.root = TakeRoot::kInput;
  const TakeResult input = process_take(*model_, take, options);
  ASSERT_EQ(generated.frames.frame_count(), take.frame_count());
  // The input's root is copied as it is; the generated one travels about as
  // far along the path as the recording does over the same 20 s.
  double recorded = 0, generated_length = 0;
  for (int64_t f = 1; f < take.frame_count(); ++f) {
    EXPECT_EQ(input.frames.frame(f)[0], take.frame(f)[0]);
    recorded += std::hypot(take.frame(f)[0], take.frame(f)[2]);
    generated_length += std::hypot(generated.frames.frame(f)[0], generated.frames.frame(f)[2]);
  }
  EXPECT_NEAR(generated_length, recorded, 0.25 * recorded);
  // The floor followed under the stream: the lowest foot stays near it in
  // 90% of frames, and the feet skate rarely.
  const auto world = world_positions(model_->skeleton(), generated.frames);
  const SkeletonFeet feet = find_feet(model_->skeleton());
  std::vector<double> lowest;
  for (int64_t f = 0; f < generated.frames.frame_count(); ++f) {
    double low = 1e9;
    for (const auto& foot : feet.joints) {
      for (int j : foot) low = std::min(low, world[static_cast<size_t>(f * 32 + j)][1]);
    }
    lowest.push_back(low);
  }
  std::sort(lowest.begin(), lowest.end());
  std::printf("lowest foot: 5%% %.0f, median %.0f, 95%% %.0f mm\n", lowest[lowest.size() / 20], lowest[lowest.size() / 2],
              lowest[lowest.size() * 19 / 20]);
  EXPECT_GT(lowest[lowest.size() / 20], -50.0);      // mm
  EXPECT_LT(lowest[lowest.size() * 19 / 20], 100.0);
  // Here 0.110 with the weights at 42,541 iterations; over the whole take
  // at 25 Hz 0.113, where those at 36,103 gave 0.079 and the recording
  // gives 0.033 (docs/RESULTS.md), without plant_feet, which takes do not
  // offer.
  EXPECT_LT(skating_ratio(model_->skeleton(), generated.frames, 50).ratio(), 0.12);
}

TEST(RootTrajectory, AModelWithoutOneStandsInPlaceAndTakesRefuseAGeneratedRoot) {
  torch::manual_seed(3);
  const TrainConfig config = test::tiny_config();
  MotionManifold model(config.model, test::small_h36m().normalization, Skeleton::h36m());
  model.train(false);
  const auto decoded = decode_codes(model, sample_codes(model, 2, 5), model.default_decoder());
  for (const auto& motion : decoded) {
    for (int64_t f = 0; f < motion.frame_count(); ++f) {
      ASSERT_EQ(motion.frame(f)[0], 0.0f);
      ASSERT_EQ(motion.frame(f)[1], 0.0f);
      ASSERT_EQ(motion.frame(f)[2], 0.0f);
    }
  }
  TakeOptions options;
  options.root = TakeRoot::kGenerated;
  try {
    TakeProcessor processor(model, options, {});
    ADD_FAILURE() << "a generated root was accepted without a trajectory network";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("root: "), std::string::npos) << e.what();
  }
}

TEST(RootTrajectory, TheCodeEntersTheFirstConvolutionOnceAClipAsIfGivenToEveryFrame) {
  // forward() adds the code's part of the first convolution once per clip;
  // the network as trained reads the code beside the pose in every frame.
  torch::manual_seed(4);
  RootTrajectory network(51, 64, TrajectoryConfig{});
  network->eval();
  c10::InferenceMode inference;
  const auto poses = at::randn({3, 40, 51}), codes = at::randn({3, 64});
  auto x = at::cat({poses, codes.unsqueeze(1).expand({3, 40, 64})}, 2).transpose(1, 2);
  const auto children = network->children()[0]->children();
  for (size_t i = 0; i < children.size(); ++i) {
    x = children[i]->as<torch::nn::Conv1d>()->forward(i == 0 ? x : at::relu(x));
  }
  x = x.transpose(1, 2);
  const auto want = at::cat({x.narrow(2, 0, 3) * kTrajectoryOutputMm, x.narrow(2, 3, 3) * kTrajectoryOutputRadians}, 2);
  const auto got = network->forward(poses, codes);
  ASSERT_EQ(got.sizes(), want.sizes());
  // Float rounding of sums taken in another order: outputs are of order 20
  // mm and 0.02 rad.
  EXPECT_LT((got - want).abs().max().item<double>(), 1e-4);
  EXPECT_GT(want.abs().max().item<double>(), 1.0);
}

TEST(RootTrajectory, TrainedNetworkIsSavedWithTheModelAndGivesTheSamePathBack) {
  if (!test::has_h36m()) GTEST_SKIP() << "H3.6M not extracted";
  torch::manual_seed(3);
  const TrainConfig config = test::tiny_config();
  MotionManifold model(config.model, test::small_h36m().normalization, Skeleton::h36m());
  model.train(false);
  std::vector<MotionFrames> motions = split_phases_keeping_root_path(
      read_motion_text((test::h36m_dataset_dir() / "S1" / "walking_1.txt").string()), 2);
  TrajectoryTrainingOptions options;
  options.iterations = 30;
  options.batch = 8;
  options.windows = 16;
  const auto report = train_root_trajectory(model, motions, options);
  EXPECT_EQ(report.iterations, 30);
  ASSERT_TRUE(model.has_trajectory());
  const auto dir = std::filesystem::temp_directory_path() / ("mm-trajectory-" + std::to_string(::getpid()));
  model.save(dir.string());
  const MotionManifold loaded = MotionManifold::load(dir.string());
  ASSERT_TRUE(loaded.has_trajectory());
  const auto codes = sample_codes(model, 2, 9);
  const auto before = decode_codes(model, codes, model.default_decoder());
  const auto after = decode_codes(loaded, codes, loaded.default_decoder());
  double largest = 0, moved = 0;
  for (size_t i = 0; i < before.size(); ++i) {
    for (int64_t f = 0; f < before[i].frame_count(); ++f) {
      for (int a = 0; a < 3; ++a) largest = std::max(largest, static_cast<double>(std::fabs(before[i].frame(f)[a] - after[i].frame(f)[a])));
      moved += std::fabs(before[i].frame(f)[0]) + std::fabs(before[i].frame(f)[2]);
    }
  }
  EXPECT_LT(largest, 1e-3);  // mm
  EXPECT_GT(moved, 0.0);     // the path is the network's, not zero
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mm
