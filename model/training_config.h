// Configuration of the networks and of a training run, with the paper's
// defaults (Sec. 3.3 and supplementary A.3) and the Table 1 variants.
//
// Plain data; safe to copy between threads.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mm {

// The shape of the networks. Defaults are the paper's model (DKGM).
struct ModelConfig {
  int pose_dims = 51;     // network input/output: the kept, normalised pose columns
  int hidden = 1024;      // GRU hidden size of the encoder and both decoders
  int latent = 64;        // size of the manifold code z
  int frames = 150;       // clip length: 6 s at 25 Hz
  bool rotation_decoder = true;
  bool velocity_decoder = true;
  bool feed_code = false;  // DKGMZ: each decoder step also sees z
};

// Weights of Eq. 8 and Eq. 15. A zero weight switches the term off, which is
// how the ablation variants are expressed (no FK layer = zero position weight).
struct LossWeights {
  double position = 5.0;       // w_p, Eq. 8
  double manifold = 0.001;     // lambda_M, Eq. 15
  double wasserstein = 0.1;    // lambda_W
  double adversarial = 0.001;  // lambda_G, Eq. 15 and 16
  double prior_variance = 1.0;  // sigma_z^2 of the prior N(0, sigma_z^2 I)
  // Not in the paper: the angle loss's weight on the root's rotation values
  // (input columns 3..5, the body's turn from one frame to the next), every
  // other value weighing 1. The decoders smooth that turn (docs/RESULTS.md,
  // "Motions that travel"), so a generated path turns less than the
  // recording's; more weight here is the remedy to try. 1 (the paper, and
  // every shipped model) leaves it out of the configuration's JSON.
  double root_rotation = 1.0;
};

// How each loss term is reduced. The paper's text and its public reference
// implementation (DK-Jang/human_motion_manifold) differ here, and the shipped
// models were trained with a third set; each choice is separate so that its
// effect can be measured alone. Every form averages over clips and frames
// unless it says otherwise.
enum class AngleReduction {
  kFrameNorm,    // "frame-norm": one norm over all D values of a frame
  kTripletMean,  // "triplet-mean": the reference, the mean of the norms of D/3 consecutive triplets
  kJointSum,     // "joint-sum": Eq. 9 as written, the sum over the D/3 joints (triplets) of each joint's norm
};
enum class PositionReduction {
  kFrameNorm,                // "frame-norm": one norm over all joints, mm / position_scale_mm
  kStandardizedTripletMean,  // "standardized-triplet-mean": the reference, coordinates standardised by the
                             // training frames' per-coordinate std, the mean of the joints' norms
  kJointSum,                 // "joint-sum": Eq. 10 as written, the sum over the joints of each joint's norm,
                             // mm / position_scale_mm
};
enum class MmdForm {
  kSingleScale,  // "single-scale": Eq. 12, C = 2 * latent * sigma_z^2, diagonal left out
  kSevenScales,  // "seven-scales": the reference, summed over C x {0.1, 0.2, 0.5, 1, 2, 5, 10},
                 // the within-set diagonal kept (still divided by n(n-1))
};
enum class AdversarialReduction {
  kHalfMean,  // "half-mean": 1/2 x the mean over clips of the squared error of a clip's mean score
  kBatchSum,  // "batch-sum": the reference, the sum over clips of the mean over the discriminator's time steps
              // of the squared error, one discriminator loss per decoder, each with the real clips
  kHalfSum,   // "half-sum": Eq. 13/14 as written, 1/2 x the sum over clips of the squared error of a clip's
              // mean score
};

// The defaults are the "frame-norm" preset, the forms every shipped model was
// trained with (see docs/RESULTS.md, "Loss forms").
struct LossForms {
  AngleReduction angle = AngleReduction::kFrameNorm;
  PositionReduction position = PositionReduction::kFrameNorm;
  MmdForm mmd = MmdForm::kSingleScale;
  AdversarialReduction adversarial = AdversarialReduction::kHalfMean;
  bool operator==(const LossForms& other) const;
};

// The names above, and three presets: "frame-norm" (the defaults above:
// frame-norm, frame-norm, single-scale, half-mean), "paper" (the paper's
// equations as written: joint-sum, joint-sum, single-scale, half-sum) and
// "reference" (all four of the reference's forms). Parsers throw InputError
// naming `field`, the value and the accepted names.
const char* loss_form_name(AngleReduction value);
const char* loss_form_name(PositionReduction value);
const char* loss_form_name(MmdForm value);
const char* loss_form_name(AdversarialReduction value);
AngleReduction parse_angle_reduction(const std::string& name, const std::string& field);
PositionReduction parse_position_reduction(const std::string& name, const std::string& field);
MmdForm parse_mmd_form(const std::string& name, const std::string& field);
AdversarialReduction parse_adversarial_reduction(const std::string& name, const std::string& field);
LossForms loss_preset(const std::string& name, const std::string& field);
// The preset's name when the forms are one of the presets, else "custom".
std::string loss_preset_name(const LossForms& forms);

struct TrainConfig {
  std::string variant = "DKGM";
  ModelConfig model;
  LossWeights weights;
  LossForms losses;
  int batch = 30;
  int64_t iterations = 60000;
  double learning_rate = 1e-3;  // Adam, both networks
  double lr_decay = 0.999;      // multiplied in every decay_every iterations
  int decay_every = 20;
  double clip_norm = 1.0;       // global gradient norm of the generator's parameters
  uint64_t seed = 1;
  int log_every = 10;           // iterations between progress reports
  int checkpoint_every = 1000;  // iterations between checkpoints; 0 = only at the end
  // Each training clip is mirrored (left and right swapped,
  // format/motion_mirror.h) with probability 1/2: H3.6M's training subjects
  // all walk their circles the same way round, and a manifold trained on
  // them does not turn the other way (docs/RESULTS.md, "Motions that
  // travel"). Off by default: the shipped models were trained without it.
  bool mirror = false;
  std::string dataset;          // prepared dataset file (see format/prepared_dataset.h)
  std::string output_dir;       // checkpoints, training log and the exported model
};

// The ranges the reader holds a configuration's sizes to; an override of
// one (TrainOverrides) is held to the same.
constexpr int kMinTrainBatch = 2;  // the MMD estimate needs two samples
constexpr int kMaxTrainBatch = 100000;
constexpr int kMinTrainHidden = 1, kMaxTrainHidden = 65536;
constexpr int64_t kMaxTrainIterations = 1'000'000'000'000;

// Values given beside a configuration that replace its own: the tool's
// `train` flags and a training job's spec. What "not given" means is written
// here once: 0, an empty optional or an empty path means the configuration's
// value.
struct TrainOverrides {
  int64_t iterations = 0;
  int batch = 0;
  int hidden = 0;  // model.hidden
  std::optional<uint64_t> seed;
  std::optional<LossForms> losses;  // a preset, applied before the forms below
  std::optional<AngleReduction> loss_angle;
  std::optional<PositionReduction> loss_position;
  std::optional<MmdForm> loss_mmd;
  std::optional<AdversarialReduction> loss_adversarial;
  std::string dataset, output_dir;
};

// A configuration resolved for a run: what it trains, whole.
struct ResolvedTrainConfig {
  TrainConfig config;
  // The configuration did not give model.pose_dims: the run sets them to its
  // dataset's kept columns (51 for H3.6M) once it has loaded it, so that one
  // configuration trains any skeleton.
  bool pose_dims_from_dataset = true;
};

// Names of the Table 1 variants: S, D, DK, DKG, DKGM, DKGMZ, Seq2seq.
const std::vector<std::string>& variant_names();

// Returns the paper's configuration for a variant. Throws InputError naming
// the value and the accepted names for an unknown variant.
TrainConfig variant_config(const std::string& variant);

// JSON text of a configuration; every field is written.
std::string to_json_text(const TrainConfig& config);

// Reads a configuration: starts from the variant's defaults (field "variant",
// default DKGM) and overrides the fields present. Unknown fields and values
// of the wrong type or range are InputErrors naming the field.
TrainConfig train_config_from_json_text(const std::string& text, const std::string& source_name);
TrainConfig read_train_config(const std::string& path);

// The configuration a run trains: `config_text` read by
// train_config_from_json_text (empty: `variant`'s defaults, variant_config),
// then each override that is given. Throws InputError: for a bad text, that
// of train_config_from_json_text (naming `source_name` and the field); for an
// override outside its field's range above, one naming `override_prefix` and
// the field ("--batch" for the tool's flag, "batch" for a job's), the value
// and the range; for an unknown variant, variant_config's. Thread safe (no
// shared state).
ResolvedTrainConfig resolve_train_config(const std::string& config_text, const std::string& variant,
                                         const TrainOverrides& overrides, const std::string& source_name,
                                         const std::string& override_prefix);

// JSON text of a resolved configuration: to_json_text(config), without
// model.pose_dims when they come from the dataset. Read back by
// resolve_train_config without overrides it resolves to the same.
std::string to_json_text(const ResolvedTrainConfig& resolved);

std::string to_json_text(const ModelConfig& config);
ModelConfig model_config_from_json_text(const std::string& text, const std::string& source_name);

}  // namespace mm
