#include "model/training_config.h"

#include <gtest/gtest.h>

#include "format/input_error.h"

namespace mm {
namespace {

std::string error_of(const std::string& json) {
  try {
    train_config_from_json_text(json, "config.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(TrainingConfig, DefaultsAreThePapersModel) {
  const TrainConfig c = variant_config("DKGM");
  EXPECT_EQ(c.model.hidden, 1024);
  EXPECT_EQ(c.model.latent, 64);
  EXPECT_EQ(c.model.frames, 150);
  EXPECT_EQ(c.batch, 30);
  EXPECT_DOUBLE_EQ(c.weights.position, 5.0);
  EXPECT_DOUBLE_EQ(c.weights.manifold, 0.001);
  EXPECT_DOUBLE_EQ(c.weights.wasserstein, 0.1);
  EXPECT_DOUBLE_EQ(c.weights.adversarial, 0.001);
  EXPECT_DOUBLE_EQ(c.learning_rate, 1e-3);
  EXPECT_DOUBLE_EQ(c.clip_norm, 1.0);
}

TEST(TrainingConfig, VariantsAddOneIngredientEach) {
  EXPECT_FALSE(variant_config("S").model.velocity_decoder);
  EXPECT_TRUE(variant_config("D").model.velocity_decoder);
  EXPECT_EQ(variant_config("D").weights.position, 0.0);
  EXPECT_GT(variant_config("DK").weights.position, 0.0);
  EXPECT_EQ(variant_config("DK").weights.adversarial, 0.0);
  EXPECT_GT(variant_config("DKG").weights.adversarial, 0.0);
  EXPECT_EQ(variant_config("DKG").weights.manifold, 0.0);
  EXPECT_TRUE(variant_config("DKGMZ").model.feed_code);
  EXPECT_FALSE(variant_config("Seq2seq").model.rotation_decoder);
}

TEST(TrainingConfig, JsonRoundTrips) {
  TrainConfig c = variant_config("DKGMZ");
  c.batch = 12;
  c.model.hidden = 256;
  c.dataset = "prepared.mmd";
  const TrainConfig back = train_config_from_json_text(to_json_text(c), "x");
  EXPECT_EQ(to_json_text(back), to_json_text(c));
}

TEST(TrainingConfig, TheRootRotationWeightIsWrittenOnlyWhenItIsNotOne) {
  TrainConfig c = variant_config("DKGM");
  EXPECT_EQ(to_json_text(c).find("root_rotation"), std::string::npos);
  c.weights.root_rotation = 8.0;
  const TrainConfig back = train_config_from_json_text(to_json_text(c), "x");
  EXPECT_EQ(back.weights.root_rotation, 8.0);
  EXPECT_EQ(to_json_text(back), to_json_text(c));
  try {
    train_config_from_json_text(R"({"weights": {"root_rotation": -1}})", "c.json");
    FAIL() << "a negative weight was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("weights.root_rotation"), std::string::npos) << e.what();
  }
}

TEST(TrainingConfig, MirrorIsOffUnlessGivenAndWrittenOnlyWhenOn) {
  TrainConfig c = variant_config("DKGM");
  EXPECT_FALSE(c.mirror);
  EXPECT_EQ(to_json_text(c).find("mirror"), std::string::npos);
  c.mirror = true;
  const TrainConfig back = train_config_from_json_text(to_json_text(c), "x");
  EXPECT_TRUE(back.mirror);
  EXPECT_EQ(to_json_text(back), to_json_text(c));
  const std::string error = error_of(R"({"mirror": 1})");
  EXPECT_NE(error.find("mirror"), std::string::npos) << error;
  EXPECT_NE(error.find("expected true or false"), std::string::npos) << error;
}

TEST(TrainingConfig, FileOverridesTheVariantDefaults) {
  const TrainConfig c = train_config_from_json_text(R"({"variant": "DK", "batch": 4, "model": {"hidden": 128}})", "c");
  EXPECT_EQ(c.batch, 4);
  EXPECT_EQ(c.model.hidden, 128);
  EXPECT_EQ(c.weights.adversarial, 0.0);
}

TEST(TrainingConfig, ErrorsNameTheFieldAndValue) {
  EXPECT_NE(error_of(R"({"variant": "XYZ"})").find("\"XYZ\""), std::string::npos);
  EXPECT_NE(error_of(R"({"batch": "thirty"})").find("batch"), std::string::npos);
  EXPECT_NE(error_of(R"({"batch": 1})").find("out of range"), std::string::npos);
  EXPECT_NE(error_of(R"({"model": {"hiden": 3}})").find("model.hiden: unknown field"), std::string::npos);
  EXPECT_NE(error_of(R"({"weights": {"position": -1}})").find("weights.position"), std::string::npos);
  EXPECT_NE(error_of("{not json").find("config.json: not valid JSON"), std::string::npos);
}

TEST(TrainingConfig, LossFormsDefaultToTheFrameNormPresetAndEachPresetSetsAllFour) {
  EXPECT_EQ(loss_preset_name(variant_config("DKGM").losses), "frame-norm");
  const LossForms frame_norm = variant_config("DKGM").losses;
  EXPECT_EQ(frame_norm.angle, AngleReduction::kFrameNorm);
  EXPECT_EQ(frame_norm.position, PositionReduction::kFrameNorm);
  EXPECT_EQ(frame_norm.mmd, MmdForm::kSingleScale);
  EXPECT_EQ(frame_norm.adversarial, AdversarialReduction::kHalfMean);
  const LossForms paper = loss_preset("paper", "losses");
  EXPECT_EQ(paper.angle, AngleReduction::kJointSum);
  EXPECT_EQ(paper.position, PositionReduction::kJointSum);
  EXPECT_EQ(paper.mmd, MmdForm::kSingleScale);
  EXPECT_EQ(paper.adversarial, AdversarialReduction::kHalfSum);
  EXPECT_EQ(loss_preset_name(paper), "paper");
  const LossForms reference = loss_preset("reference", "losses");
  EXPECT_EQ(reference.angle, AngleReduction::kTripletMean);
  EXPECT_EQ(reference.position, PositionReduction::kStandardizedTripletMean);
  EXPECT_EQ(reference.mmd, MmdForm::kSevenScales);
  EXPECT_EQ(reference.adversarial, AdversarialReduction::kBatchSum);
  EXPECT_EQ(loss_preset_name(reference), "reference");
}

TEST(TrainingConfig, EveryLossFormNameReadsBack) {
  for (const char* name : {"frame-norm", "triplet-mean", "joint-sum"}) {
    EXPECT_STREQ(loss_form_name(parse_angle_reduction(name, "a")), name);
  }
  for (const char* name : {"frame-norm", "standardized-triplet-mean", "joint-sum"}) {
    EXPECT_STREQ(loss_form_name(parse_position_reduction(name, "p")), name);
  }
  for (const char* name : {"half-mean", "batch-sum", "half-sum"}) {
    EXPECT_STREQ(loss_form_name(parse_adversarial_reduction(name, "g")), name);
  }
}

TEST(TrainingConfig, Seq2seqTrainsOnTheReconstructionLossOfEq8) {
  // Supplementary A.1: "The loss function is the same as our motion
  // reconstruction loss": angles and FK positions, nothing else.
  const TrainConfig c = variant_config("Seq2seq");
  EXPECT_FALSE(c.model.rotation_decoder);
  EXPECT_TRUE(c.model.velocity_decoder);
  EXPECT_EQ(c.weights.position, variant_config("DKGM").weights.position);
  EXPECT_EQ(c.weights.adversarial, 0.0);
  EXPECT_EQ(c.weights.manifold, 0.0);
  EXPECT_EQ(c.weights.wasserstein, 0.0);
}

TEST(TrainingConfig, LossFormsReadFromJsonPresetFirstThenEachForm) {
  const TrainConfig c =
      train_config_from_json_text(R"({"losses": {"preset": "reference", "mmd": "single-scale"}})", "c");
  EXPECT_EQ(c.losses.angle, AngleReduction::kTripletMean);
  EXPECT_EQ(c.losses.mmd, MmdForm::kSingleScale);
  EXPECT_EQ(loss_preset_name(c.losses), "custom");
  const TrainConfig back = train_config_from_json_text(to_json_text(c), "x");
  EXPECT_TRUE(back.losses == c.losses);
  EXPECT_NE(error_of(R"({"losses": {"adversarial": "sum"}})").find("losses.adversarial: unknown value \"sum\""),
            std::string::npos);
  EXPECT_NE(error_of(R"({"losses": {"preset": "paperish"}})").find("losses.preset"), std::string::npos);
  EXPECT_NE(error_of(R"({"losses": {"angles": "frame-norm"}})").find("losses.angles: unknown field"),
            std::string::npos);
}

// resolve_train_config is the one rule of the tool's `train` flags and a
// training job's spec: what is not given (0, no value) is the configuration's.
TEST(TrainingConfig, ResolvingKeepsTheConfigurationsValuesWhereNoOverrideIsGiven) {
  const std::string text = R"({"variant": "DK", "batch": 8, "iterations": 500, "seed": 9, "model": {"hidden": 128}})";
  const ResolvedTrainConfig none = resolve_train_config(text, "S", TrainOverrides{}, "c", "--");
  EXPECT_EQ(to_json_text(none.config), to_json_text(train_config_from_json_text(text, "c")));
  EXPECT_EQ(none.config.variant, "DK");  // the text replaces the variant

  TrainOverrides overrides;
  overrides.hidden = 16;
  overrides.seed = 0;  // a seed given, even 0, replaces the configuration's
  overrides.loss_mmd = MmdForm::kSevenScales;
  overrides.output_dir = "run";
  const TrainConfig c = resolve_train_config(text, "S", overrides, "c", "--").config;
  EXPECT_EQ(c.model.hidden, 16);
  EXPECT_EQ(c.seed, 0u);
  EXPECT_EQ(c.losses.mmd, MmdForm::kSevenScales);
  EXPECT_EQ(c.losses.angle, AngleReduction::kFrameNorm);
  EXPECT_EQ(c.output_dir, "run");
  EXPECT_EQ(c.batch, 8);
  EXPECT_EQ(c.iterations, 500);
  EXPECT_EQ(c.dataset, "");
  EXPECT_EQ(c.weights.adversarial, 0.0);  // DK's

  // No text: the variant's defaults.
  overrides = TrainOverrides{};
  overrides.iterations = 40;
  const TrainConfig v = resolve_train_config("", "D", overrides, "c", "--").config;
  TrainConfig expected = variant_config("D");
  expected.iterations = 40;
  EXPECT_EQ(to_json_text(v), to_json_text(expected));
}

TEST(TrainingConfig, AnOverrideOutsideItsFieldsRangeNamesTheFieldTheValueAndTheRange) {
  const auto error_of_override = [](const TrainOverrides& overrides, const std::string& prefix) -> std::string {
    try {
      resolve_train_config("", "DKGM", overrides, "c", prefix);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  TrainOverrides batch;
  batch.batch = 1;
  EXPECT_EQ(error_of_override(batch, "--"), "--batch: value 1 out of range [2, 100000]");
  TrainOverrides hidden;
  hidden.hidden = 70000;
  EXPECT_EQ(error_of_override(hidden, ""), "hidden: value 70000 out of range [1, 65536]");
  TrainOverrides iterations;
  iterations.iterations = -3;
  EXPECT_EQ(error_of_override(iterations, "--"), "--iterations: value -3 out of range [1, 1000000000000]");
}

// The pose dimensions are the dataset's unless the configuration fixes them;
// the resolved JSON keeps that, so that reading it back resolves the same.
TEST(TrainingConfig, AResolvedConfigurationReadsBackToItselfAndLeavesPoseDimsToTheDataset) {
  TrainOverrides overrides;
  overrides.batch = 4;
  overrides.seed = 3;
  const ResolvedTrainConfig from_dataset =
      resolve_train_config(R"({"variant": "D", "learning_rate": 0.002})", "", overrides, "c", "");
  EXPECT_TRUE(from_dataset.pose_dims_from_dataset);
  const std::string text = to_json_text(from_dataset);
  EXPECT_EQ(text.find("pose_dims"), std::string::npos) << text;
  const ResolvedTrainConfig back = resolve_train_config(text, "", TrainOverrides{}, "c", "");
  EXPECT_TRUE(back.pose_dims_from_dataset);
  EXPECT_EQ(to_json_text(back), text);
  EXPECT_EQ(back.config.batch, 4);
  EXPECT_EQ(back.config.seed, 3u);
  EXPECT_DOUBLE_EQ(back.config.learning_rate, 0.002);

  const ResolvedTrainConfig fixed = resolve_train_config(R"({"model": {"pose_dims": 60}})", "", overrides, "c", "");
  EXPECT_FALSE(fixed.pose_dims_from_dataset);
  const ResolvedTrainConfig fixed_back = resolve_train_config(to_json_text(fixed), "", TrainOverrides{}, "c", "");
  EXPECT_FALSE(fixed_back.pose_dims_from_dataset);
  EXPECT_EQ(fixed_back.config.model.pose_dims, 60);
  EXPECT_TRUE(resolve_train_config("", "DKGM", overrides, "c", "").pose_dims_from_dataset);
}

}  // namespace
}  // namespace mm
