#include "model/motion_manifold.h"

#include <torch/serialize/input-archive.h>
#include <torch/serialize/output-archive.h>

#include <filesystem>
#include <map>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "format/json_text.h"

namespace mm {
namespace {

constexpr const char* kManifestFormat = "motion-manifold-model";
constexpr int kManifestVersion = 1;

DecoderShape decoder_shape(const ModelConfig& c, bool residual) {
  return DecoderShape{c.pose_dims, c.hidden, c.latent, c.frames, residual, c.feed_code};
}

void save_module(const torch::nn::Module& module, const std::string& path) {
  torch::serialize::OutputArchive archive;
  module.save(archive);
  std::ostringstream bytes;
  archive.save_to(bytes);
  write_file_atomically(path, bytes.str());
}

void load_module(torch::nn::Module& module, const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path + ": missing network weights file");
  // Module::load replaces each tensor with the stored one whatever its
  // shape, so weights of another network size would load and fail only at
  // the first inference: compare with the shapes the manifest implies.
  std::map<std::string, std::vector<int64_t>> expected;
  for (const auto& item : module.named_parameters()) expected[item.key()] = item.value().sizes().vec();
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path, at::kCPU);  // weights saved from a GPU load anywhere; load() moves them on
    module.load(archive);
  } catch (const c10::Error& e) {
    throw InputError(path + ": unreadable or mismatched network weights: " + e.what_without_backtrace());
  }
  for (const auto& item : module.named_parameters()) {
    const auto& shape = expected[item.key()];
    if (item.value().sizes().vec() != shape) {
      throw InputError(path + ": " + item.key() + " has shape " + c10::str(item.value().sizes()) +
                       " where the manifest's network needs " + c10::str(at::IntArrayRef(shape)));
    }
  }
}

}  // namespace

const char* decoder_name(DecoderKind kind) { return kind == DecoderKind::kRotation ? "rotation" : "velocity"; }

DecoderKind parse_decoder_kind(const std::string& name) {
  if (name == "rotation") return DecoderKind::kRotation;
  if (name == "velocity") return DecoderKind::kVelocity;
  throw InputError("decoder", "unknown value \"" + name + "\", expected rotation or velocity");
}

MotionManifold::MotionManifold(const ModelConfig& config, PoseNormalization normalization, Skeleton skeleton)
    : config_(config), normalization_(std::move(normalization)), skeleton_(std::move(skeleton)), fk_(skeleton_) {
  if (normalization_.dims() != config_.pose_dims) {
    throw InputError("model.pose_dims", std::to_string(config_.pose_dims) + " does not match the " +
                     std::to_string(normalization_.dims()) + " columns kept by the normalisation");
  }
  if (normalization_.input_columns() != 3 + 3 * skeleton_.joint_count()) {
    throw InputError("normalization", std::to_string(normalization_.input_columns()) +
                     " columns do not fit the skeleton's " + std::to_string(skeleton_.joint_count()) + " joints");
  }
  encoder_ = Encoder(config_.pose_dims, config_.hidden, config_.latent);
  if (config_.rotation_decoder) rotation_decoder_ = Decoder(decoder_shape(config_, false));
  if (config_.velocity_decoder) velocity_decoder_ = Decoder(decoder_shape(config_, true));
  discriminator_ = Discriminator(config_.pose_dims);
  build_tensors();
}

void MotionManifold::build_tensors() {
  const int columns = normalization_.input_columns(), dims = normalization_.dims();
  kept_mean_ = at::empty({dims});
  kept_std_ = at::empty({dims});
  kept_index_ = at::empty({dims}, at::kLong);
  scatter_ = at::zeros({dims, columns});
  base_ = at::empty({columns});
  for (int c = 0; c < columns; ++c) base_[c] = normalization_.mean[c];
  // Root translation is not modelled: decoded frames carry none.
  for (int c = 0; c < 3; ++c) base_[c] = 0.0f;
  for (int d = 0; d < dims; ++d) {
    const int c = normalization_.kept_columns[d];
    kept_mean_[d] = normalization_.mean[c];
    kept_std_[d] = normalization_.stddev[c];
    kept_index_[d] = c;
    scatter_[d][c] = 1.0f;
    base_[c] = 0.0f;
  }
  kept_mean_ = kept_mean_.to(device_);
  kept_std_ = kept_std_.to(device_);
  kept_index_ = kept_index_.to(device_);
  scatter_ = scatter_.to(device_);
  base_ = base_.to(device_);
}

DecoderKind MotionManifold::default_decoder() const {
  return has_decoder(DecoderKind::kRotation) ? DecoderKind::kRotation : DecoderKind::kVelocity;
}

std::vector<at::Tensor> MotionManifold::generator_parameters() const {
  std::vector<at::Tensor> params = encoder_->parameters();
  for (const auto* d : {&rotation_decoder_, &velocity_decoder_}) {
    if (d->is_empty()) continue;
    auto p = (*d)->parameters();
    params.insert(params.end(), p.begin(), p.end());
  }
  return params;
}

void MotionManifold::to(at::Device device) {
  discard_inference_packs();
  device_ = device;
  encoder_->to(device);
  if (!rotation_decoder_.is_empty()) rotation_decoder_->to(device);
  if (!velocity_decoder_.is_empty()) velocity_decoder_->to(device);
  discriminator_->to(device);
  if (!trajectory_.is_empty()) trajectory_->to(device);
  fk_.to(device);
  build_tensors();
}

void MotionManifold::train(bool on) {
  if (on) discard_inference_packs();
  encoder_->train(on);
  if (!rotation_decoder_.is_empty()) rotation_decoder_->train(on);
  if (!velocity_decoder_.is_empty()) velocity_decoder_->train(on);
  discriminator_->train(on);
  if (!trajectory_.is_empty()) trajectory_->train(on);
}

void MotionManifold::set_trajectory(RootTrajectory trajectory, const std::string& training_json) {
  trajectory_ = std::move(trajectory);
  trajectory_training_json_ = training_json;
  if (!trajectory_.is_empty()) trajectory_->to(device_);
}

void MotionManifold::pack_for_inference(Precision precision) {
  encoder_->pack_for_inference(precision);
  for (auto* decoder : {&rotation_decoder_, &velocity_decoder_}) {
    if (!decoder->is_empty()) (*decoder)->pack_for_inference(precision);
  }
  inference_precision_ = precision;
}

void MotionManifold::discard_inference_packs() {
  encoder_->discard_inference_pack();
  for (auto* decoder : {&rotation_decoder_, &velocity_decoder_}) {
    if (!decoder->is_empty()) (*decoder)->discard_inference_pack();
  }
  inference_precision_.reset();
}

at::Tensor MotionManifold::to_raw(const at::Tensor& normalized) const {
  return base_ + at::matmul(normalized * kept_std_ + kept_mean_, scatter_);
}

at::Tensor MotionManifold::to_normalized(const at::Tensor& raw) const {
  return (raw.index_select(-1, kept_index_) - kept_mean_) / kept_std_;
}

at::Tensor MotionManifold::positions_mm(const at::Tensor& normalized) const { return fk_.positions(to_raw(normalized)); }

at::Tensor MotionManifold::positions_scaled(const at::Tensor& normalized) const {
  return positions_mm(normalized) / normalization_.position_scale_mm;
}

at::Tensor MotionManifold::encode(const at::Tensor& normalized) const {
  return encoder_->encode(normalized.to(device_));
}

at::Tensor MotionManifold::decode(const at::Tensor& codes, DecoderKind kind) const {
  if (!has_decoder(kind)) {
    throw InputError("decoder", std::string("this model has no ") + decoder_name(kind) + " decoder");
  }
  return decoder(kind)->generate(codes.to(device_));
}

void MotionManifold::save(const std::string& dir, const std::string& provenance_json) const {
  std::filesystem::create_directories(dir);
  save_module(*encoder_, dir + "/encoder.pt");
  if (!rotation_decoder_.is_empty()) save_module(*rotation_decoder_, dir + "/rotation_decoder.pt");
  if (!velocity_decoder_.is_empty()) save_module(*velocity_decoder_, dir + "/velocity_decoder.pt");
  save_module(*discriminator_, dir + "/discriminator.pt");
  nlohmann::json manifest = {
      {"format", kManifestFormat},
      {"version", kManifestVersion},
      {"model", nlohmann::json::parse(to_json_text(config_))},
      {"normalization", nlohmann::json::parse(normalization_.to_json_text())},
      {"skeleton", nlohmann::json::parse(skeleton_.to_json_text())},
      {"provenance", nlohmann::json::parse(provenance_json)},
  };
  if (!trajectory_.is_empty()) {
    save_module(*trajectory_, dir + "/trajectory.pt");
    manifest["trajectory"] = {{"shape", nlohmann::json::parse(to_json_text(trajectory_->config()))},
                              {"training", nlohmann::json::parse(trajectory_training_json_)}};
  }
  write_file_atomically(dir + "/manifest.json", manifest.dump(1));
}

MotionManifold MotionManifold::load(const std::string& dir, at::Device device) {
  const std::string manifest_path = dir + "/manifest.json";
  const nlohmann::json manifest = parse_json_text(read_whole_file(manifest_path), manifest_path);
  if (!manifest.is_object() || manifest.value("format", "") != kManifestFormat) {
    throw InputError(manifest_path + ": format: expected \"" + std::string(kManifestFormat) + "\"");
  }
  if (manifest.value("version", 0) != kManifestVersion) {
    throw InputError(manifest_path + ": version: expected " + std::to_string(kManifestVersion) + ", found " +
                     manifest.value("version", nlohmann::json()).dump());
  }
  for (const char* key : {"model", "normalization", "skeleton"}) {
    if (!manifest.contains(key)) throw InputError(manifest_path + ": missing field \"" + key + "\"");
  }
  MotionManifold model(model_config_from_json_text(manifest["model"].dump(), manifest_path + ": model"),
                       PoseNormalization::from_json_text(manifest["normalization"].dump(), manifest_path + ": normalization"),
                       Skeleton::from_json_text(manifest["skeleton"].dump(), manifest_path + ": skeleton"));
  load_module(*model.encoder_, dir + "/encoder.pt");
  if (model.config_.rotation_decoder) load_module(*model.rotation_decoder_, dir + "/rotation_decoder.pt");
  if (model.config_.velocity_decoder) load_module(*model.velocity_decoder_, dir + "/velocity_decoder.pt");
  load_module(*model.discriminator_, dir + "/discriminator.pt");
  if (manifest.contains("provenance")) model.provenance_json_ = manifest["provenance"].dump();
  if (manifest.contains("trajectory")) {
    const auto& trajectory = manifest["trajectory"];
    const std::string source = manifest_path + ": trajectory";
    if (!trajectory.is_object() || !trajectory.contains("shape")) throw InputError(source + ": missing field \"shape\"");
    RootTrajectory network(model.config_.pose_dims, model.config_.latent,
                           trajectory_config_from_json_text(trajectory["shape"].dump(), source + ".shape"));
    load_module(*network, dir + "/trajectory.pt");
    model.set_trajectory(network, trajectory.value("training", nlohmann::json::object()).dump());
  }
  model.to(device);
  model.train(false);
  if (device.is_cpu()) model.pack_for_inference(Precision::kFp32);
  return model;
}

}  // namespace mm
