#include "model/training_config.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "format/input_error.h"
#include "format/json_text.h"

namespace mm {
namespace {

using nlohmann::json;

json model_to_json(const ModelConfig& m) {
  return {{"pose_dims", m.pose_dims},
          {"hidden", m.hidden},
          {"latent", m.latent},
          {"frames", m.frames},
          {"rotation_decoder", m.rotation_decoder},
          {"velocity_decoder", m.velocity_decoder},
          {"feed_code", m.feed_code}};
}

json weights_to_json(const LossWeights& w) {
  json weights = {{"position", w.position},
                  {"manifold", w.manifold},
                  {"wasserstein", w.wasserstein},
                  {"adversarial", w.adversarial},
                  {"prior_variance", w.prior_variance}};
  // Absent means 1: the configurations of earlier models read, and write, as before.
  if (w.root_rotation != 1.0) weights["root_rotation"] = w.root_rotation;
  return weights;
}

json losses_to_json(const LossForms& f) {
  return {{"preset", loss_preset_name(f)},
          {"angle", loss_form_name(f.angle)},
          {"position", loss_form_name(f.position)},
          {"mmd", loss_form_name(f.mmd)},
          {"adversarial", loss_form_name(f.adversarial)}};
}

// One parser for the four enumerations: the names in declaration order.
template <typename Enum, size_t N>
Enum parse_named(const std::string& name, const std::string& field, const char* const (&names)[N]) {
  std::string accepted;
  for (size_t i = 0; i < N; ++i) {
    if (name == names[i]) return static_cast<Enum>(i);
    accepted += std::string(i ? ", " : "") + "\"" + names[i] + "\"";
  }
  throw InputError(field, "unknown value \"" + name + "\", expected one of " + accepted);
}

constexpr const char* kAngleNames[] = {"frame-norm", "triplet-mean", "joint-sum"};
constexpr const char* kPositionNames[] = {"frame-norm", "standardized-triplet-mean", "joint-sum"};
constexpr const char* kMmdNames[] = {"single-scale", "seven-scales"};
constexpr const char* kAdversarialNames[] = {"half-mean", "batch-sum", "half-sum"};

// Reads the fields of one JSON object into a struct, rejecting unknown keys
// and wrong types with the full field path in the message.
class FieldReader {
 public:
  FieldReader(const json& object, std::string path, std::string source)
      : object_(object), path_(std::move(path)), source_(std::move(source)) {
    if (!object_.is_object()) fail(path_, "expected an object");
  }
  ~FieldReader() noexcept(false) {
    if (std::uncaught_exceptions() > 0) return;
    for (auto it = object_.begin(); it != object_.end(); ++it) {
      if (!seen_.count(it.key())) fail(path_ + it.key(), "unknown field");
    }
  }
  template <typename T>
  void read(const std::string& key, T& target, double min = -1e300, double max = 1e300) {
    seen_.insert(key);
    auto it = object_.find(key);
    if (it == object_.end()) return;
    const std::string field = path_ + key;
    if constexpr (std::is_same_v<T, bool>) {
      if (!it->is_boolean()) fail(field, "expected true or false, found " + it->dump());
      target = it->template get<bool>();
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!it->is_string()) fail(field, "expected a string, found " + it->dump());
      target = it->template get<std::string>();
    } else if constexpr (std::is_integral_v<T>) {
      if (!it->is_number_integer() && !it->is_number_unsigned()) fail(field, "expected an integer, found " + it->dump());
      const double v = it->template get<double>();
      if (v < min || v > max) fail(field, "value " + it->dump() + " out of range [" + num(min) + ", " + num(max) + "]");
      target = it->template get<T>();
    } else {
      if (!it->is_number()) fail(field, "expected a number, found " + it->dump());
      const double v = it->template get<double>();
      if (!(v >= min && v <= max)) fail(field, "value " + it->dump() + " out of range [" + num(min) + ", " + num(max) + "]");
      target = static_cast<T>(v);
    }
  }
  const json* child(const std::string& key) {
    seen_.insert(key);
    auto it = object_.find(key);
    return it == object_.end() ? nullptr : &*it;
  }
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(source_ + ": " + field + ": " + what);
  }

 private:
  static std::string num(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  }
  const json& object_;
  std::string path_, source_;
  std::set<std::string> seen_;
};

void read_model(const json& j, ModelConfig& m, const std::string& path, const std::string& source) {
  FieldReader r(j, path, source);
  r.read("pose_dims", m.pose_dims, 1, 10000);
  r.read("hidden", m.hidden, kMinTrainHidden, kMaxTrainHidden);
  r.read("latent", m.latent, 1, 65536);
  r.read("frames", m.frames, 8, 100000);
  r.read("rotation_decoder", m.rotation_decoder);
  r.read("velocity_decoder", m.velocity_decoder);
  r.read("feed_code", m.feed_code);
  if (!m.rotation_decoder && !m.velocity_decoder) r.fail(path + "rotation_decoder", "at least one decoder must be on");
}

}  // namespace

bool LossForms::operator==(const LossForms& o) const {
  return angle == o.angle && position == o.position && mmd == o.mmd && adversarial == o.adversarial;
}

const char* loss_form_name(AngleReduction v) { return kAngleNames[static_cast<int>(v)]; }
const char* loss_form_name(PositionReduction v) { return kPositionNames[static_cast<int>(v)]; }
const char* loss_form_name(MmdForm v) { return kMmdNames[static_cast<int>(v)]; }
const char* loss_form_name(AdversarialReduction v) { return kAdversarialNames[static_cast<int>(v)]; }

AngleReduction parse_angle_reduction(const std::string& name, const std::string& field) {
  return parse_named<AngleReduction>(name, field, kAngleNames);
}
PositionReduction parse_position_reduction(const std::string& name, const std::string& field) {
  return parse_named<PositionReduction>(name, field, kPositionNames);
}
MmdForm parse_mmd_form(const std::string& name, const std::string& field) {
  return parse_named<MmdForm>(name, field, kMmdNames);
}
AdversarialReduction parse_adversarial_reduction(const std::string& name, const std::string& field) {
  return parse_named<AdversarialReduction>(name, field, kAdversarialNames);
}

LossForms loss_preset(const std::string& name, const std::string& field) {
  if (name == "frame-norm") return LossForms{};
  if (name == "paper") {
    return LossForms{AngleReduction::kJointSum, PositionReduction::kJointSum, MmdForm::kSingleScale,
                     AdversarialReduction::kHalfSum};
  }
  if (name == "reference") {
    return LossForms{AngleReduction::kTripletMean, PositionReduction::kStandardizedTripletMean, MmdForm::kSevenScales,
                     AdversarialReduction::kBatchSum};
  }
  throw InputError(field, "unknown value \"" + name + "\", expected one of \"frame-norm\", \"paper\", \"reference\"");
}

std::string loss_preset_name(const LossForms& forms) {
  for (const char* name : {"frame-norm", "paper", "reference"}) {
    if (forms == loss_preset(name, "")) return name;
  }
  return "custom";
}

const std::vector<std::string>& variant_names() {
  static const std::vector<std::string> names{"S", "D", "DK", "DKG", "DKGM", "DKGMZ", "Seq2seq"};
  return names;
}

TrainConfig variant_config(const std::string& variant) {
  TrainConfig c;
  c.variant = variant;
  auto& m = c.model;
  auto& w = c.weights;
  // Each variant adds one ingredient to the previous one (Sec. 5.1).
  if (variant == "S") {
    m.velocity_decoder = false;
    w.position = w.adversarial = w.manifold = 0;
  } else if (variant == "D") {
    w.position = w.adversarial = w.manifold = 0;
  } else if (variant == "DK") {
    w.adversarial = w.manifold = 0;
  } else if (variant == "DKG") {
    w.manifold = 0;
  } else if (variant == "DKGM") {
  } else if (variant == "DKGMZ") {
    m.feed_code = true;
  } else if (variant == "Seq2seq") {
    // [MBR17] with a 64-d bottleneck: one residual decoder. Its loss is "the
    // same as our motion reconstruction loss" (supplementary A.1): Eq. 8,
    // angles and FK positions; no prior, manifold or adversarial term.
    m.rotation_decoder = false;
    w.adversarial = w.manifold = w.wasserstein = 0;
  } else {
    std::string names;
    for (const auto& n : variant_names()) names += (names.empty() ? "" : ", ") + n;
    throw InputError("variant", "unknown value \"" + variant + "\", expected one of " + names);
  }
  return c;
}

std::string to_json_text(const ModelConfig& config) { return model_to_json(config).dump(2); }

ModelConfig model_config_from_json_text(const std::string& text, const std::string& source_name) {
  ModelConfig m;
  read_model(parse_json_text(text, source_name), m, "", source_name);
  return m;
}

std::string to_json_text(const TrainConfig& c) {
  json j = {{"variant", c.variant},
            {"model", model_to_json(c.model)},
            {"weights", weights_to_json(c.weights)},
            {"losses", losses_to_json(c.losses)},
            {"batch", c.batch},
            {"iterations", c.iterations},
            {"learning_rate", c.learning_rate},
            {"lr_decay", c.lr_decay},
            {"decay_every", c.decay_every},
            {"clip_norm", c.clip_norm},
            {"seed", c.seed},
            {"log_every", c.log_every},
            {"checkpoint_every", c.checkpoint_every},
            {"dataset", c.dataset},
            {"output_dir", c.output_dir}};
  // Absent means off: earlier configurations read, and write, as before.
  if (c.mirror) j["mirror"] = true;
  return j.dump(2);
}

TrainConfig train_config_from_json_text(const std::string& text, const std::string& source_name) {
  const json j = parse_json_text(text, source_name);
  if (!j.is_object()) throw InputError(source_name + ": expected a JSON object");
  std::string variant = "DKGM";
  if (j.contains("variant")) {
    if (!j["variant"].is_string()) throw InputError(source_name + ": variant: expected a string, found " + j["variant"].dump());
    variant = j["variant"].get<std::string>();
  }
  TrainConfig c = variant_config(variant);
  FieldReader r(j, "", source_name);
  r.read("variant", c.variant);
  if (const json* m = r.child("model")) read_model(*m, c.model, "model.", source_name);
  if (const json* w = r.child("weights")) {
    FieldReader wr(*w, "weights.", source_name);
    wr.read("position", c.weights.position, 0, 1e6);
    wr.read("manifold", c.weights.manifold, 0, 1e6);
    wr.read("wasserstein", c.weights.wasserstein, 0, 1e6);
    wr.read("adversarial", c.weights.adversarial, 0, 1e6);
    wr.read("prior_variance", c.weights.prior_variance, 1e-6, 1e6);
    wr.read("root_rotation", c.weights.root_rotation, 0, 1e6);
  }
  if (const json* l = r.child("losses")) {
    // The preset first, then any form named beside it overrides its part.
    FieldReader lr(*l, "losses.", source_name);
    std::string preset, angle, position, mmd, adversarial;
    lr.read("preset", preset);
    lr.read("angle", angle);
    lr.read("position", position);
    lr.read("mmd", mmd);
    lr.read("adversarial", adversarial);
    const std::string at = source_name + ": losses.";
    if (!preset.empty() && preset != "custom") c.losses = loss_preset(preset, at + "preset");
    if (!angle.empty()) c.losses.angle = parse_angle_reduction(angle, at + "angle");
    if (!position.empty()) c.losses.position = parse_position_reduction(position, at + "position");
    if (!mmd.empty()) c.losses.mmd = parse_mmd_form(mmd, at + "mmd");
    if (!adversarial.empty()) c.losses.adversarial = parse_adversarial_reduction(adversarial, at + "adversarial");
  }
  r.read("batch", c.batch, kMinTrainBatch, kMaxTrainBatch);
  r.read("iterations", c.iterations, 0, static_cast<double>(kMaxTrainIterations));
  r.read("learning_rate", c.learning_rate, 0, 10);
  r.read("lr_decay", c.lr_decay, 0, 1);
  r.read("decay_every", c.decay_every, 1, 1e9);
  r.read("clip_norm", c.clip_norm, 0, 1e9);
  r.read("seed", c.seed);
  r.read("log_every", c.log_every, 1, 1e9);
  r.read("checkpoint_every", c.checkpoint_every, 0, 1e9);
  r.read("mirror", c.mirror);
  r.read("dataset", c.dataset);
  r.read("output_dir", c.output_dir);
  return c;
}

ResolvedTrainConfig resolve_train_config(const std::string& config_text, const std::string& variant,
                                         const TrainOverrides& o, const std::string& source_name,
                                         const std::string& override_prefix) {
  ResolvedTrainConfig resolved;
  TrainConfig& c = resolved.config;
  if (config_text.empty()) {
    c = variant_config(variant);
  } else {
    c = train_config_from_json_text(config_text, source_name);
    const json document = parse_json_text(config_text, source_name);  // read without error just above
    resolved.pose_dims_from_dataset = !(document.contains("model") && document["model"].contains("pose_dims"));
  }
  const auto check = [&override_prefix](const char* field, int64_t value, int64_t min, int64_t max) {
    if (value < min || value > max) {
      throw InputError(override_prefix + field + ": value " + std::to_string(value) + " out of range [" +
                       std::to_string(min) + ", " + std::to_string(max) + "]");
    }
  };
  // 0 (or nothing) is "the configuration's": only a value given replaces it.
  if (o.iterations != 0) {
    check("iterations", o.iterations, 1, kMaxTrainIterations);
    c.iterations = o.iterations;
  }
  if (o.batch != 0) {
    check("batch", o.batch, kMinTrainBatch, kMaxTrainBatch);
    c.batch = o.batch;
  }
  if (o.hidden != 0) {
    check("hidden", o.hidden, kMinTrainHidden, kMaxTrainHidden);
    c.model.hidden = o.hidden;
  }
  if (o.seed) c.seed = *o.seed;
  if (o.losses) c.losses = *o.losses;
  if (o.loss_angle) c.losses.angle = *o.loss_angle;
  if (o.loss_position) c.losses.position = *o.loss_position;
  if (o.loss_mmd) c.losses.mmd = *o.loss_mmd;
  if (o.loss_adversarial) c.losses.adversarial = *o.loss_adversarial;
  if (!o.dataset.empty()) c.dataset = o.dataset;
  if (!o.output_dir.empty()) c.output_dir = o.output_dir;
  return resolved;
}

std::string to_json_text(const ResolvedTrainConfig& resolved) {
  json j = json::parse(to_json_text(resolved.config));
  if (resolved.pose_dims_from_dataset) j["model"].erase("pose_dims");
  return j.dump(2);
}

TrainConfig read_train_config(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open training configuration");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return train_config_from_json_text(buffer.str(), path);
}

}  // namespace mm
