// A motion manifold: the networks of Sec. 3.2 together with everything needed
// to use them on raw motion (the pose normalisation, the skeleton for FK and
// the network shape). This is what a trained model is, on disk and in memory.
//
// Thread safety: after load and eval(), the const inference helpers and the
// decoders' generate() may be called concurrently. Training mutates it from
// one thread.
#pragma once

#include <ATen/ATen.h>

#include <optional>
#include <string>

#include "format/pose_normalization.h"
#include "format/skeleton.h"
#include "model/decoder.h"
#include "model/discriminator.h"
#include "model/encoder.h"
#include "model/forward_kinematics.h"
#include "model/root_trajectory.h"
#include "model/training_config.h"

namespace mm {

enum class DecoderKind { kRotation, kVelocity };
const char* decoder_name(DecoderKind kind);  // "rotation" / "velocity"
// Parses "rotation" or "velocity"; InputError naming the value otherwise.
DecoderKind parse_decoder_kind(const std::string& name);

class MotionManifold {
 public:
  // Fresh, randomly initialised networks (seeded by the caller through
  // torch's generator) on the CPU.
  MotionManifold(const ModelConfig& config, PoseNormalization normalization, Skeleton skeleton);

  const ModelConfig& config() const { return config_; }
  const PoseNormalization& normalization() const { return normalization_; }
  const Skeleton& skeleton() const { return skeleton_; }
  at::Device device() const { return device_; }

  Encoder& encoder() { return encoder_; }
  const Encoder& encoder() const { return encoder_; }
  // Null when the configuration has no such decoder.
  Decoder& decoder(DecoderKind kind) { return kind == DecoderKind::kRotation ? rotation_decoder_ : velocity_decoder_; }
  const Decoder& decoder(DecoderKind kind) const {
    return kind == DecoderKind::kRotation ? rotation_decoder_ : velocity_decoder_;
  }
  bool has_decoder(DecoderKind kind) const { return !decoder(kind).is_empty(); }
  // The decoder the applications use: rotation if present (Sec. 5), else velocity.
  DecoderKind default_decoder() const;
  Discriminator& discriminator() { return discriminator_; }
  const Discriminator& discriminator() const { return discriminator_; }

  // The root trajectory network (root_trajectory.h), trained apart from the
  // manifold after it; a model without one generates motion that stays in
  // place (root translation zero), as the paper's does.
  bool has_trajectory() const { return !trajectory_.is_empty(); }
  // The network (a shared handle); empty without one.
  RootTrajectory trajectory() const { return trajectory_; }
  // Installs a trajectory network (on the model's device); `training_json`
  // is free JSON text kept in the manifest beside its shape (how it was
  // trained). Not concurrently with inference.
  void set_trajectory(RootTrajectory trajectory, const std::string& training_json = "{}");
  const std::string& trajectory_training_json() const { return trajectory_training_json_; }

  // All generator parameters (encoder and decoders), for the optimiser.
  std::vector<at::Tensor> generator_parameters() const;

  void to(at::Device device);
  void train(bool on);

  // Packs the encoder's and decoders' inference weights in `precision`
  // (packed_linear.h) for encode() and decode() on the CPU; load() packs
  // fp32. to() and train(true) discard the packs, since the weights they
  // were packed from are then moved or about to change. Not concurrently
  // with inference. InputError if the precision is not available here.
  void pack_for_inference(Precision precision);
  // Drops the packs: encode() and decode() multiply with the weights as they are.
  void discard_inference_packs();
  // The precision the packs hold, or nothing when the weights are used as
  // they are.
  std::optional<Precision> inference_precision() const { return inference_precision_; }

  // Normalised poses (..., D) to raw frames (..., input columns): dropped
  // root translation is zero, other unmodelled columns take their training
  // mean. Differentiable.
  at::Tensor to_raw(const at::Tensor& normalized) const;
  // Raw frames (..., input columns) to normalised poses (..., D).
  at::Tensor to_normalized(const at::Tensor& raw) const;
  // Normalised poses (..., D) to joint positions (..., J, 3) in millimetres.
  at::Tensor positions_mm(const at::Tensor& normalized) const;
  // The same in the loss's unit: millimetres / normalization().position_scale_mm.
  at::Tensor positions_scaled(const at::Tensor& normalized) const;

  // Inference without autograd: normalised clips (B, frames, D) to codes
  // (B, latent), and codes to clips through one decoder (InputError if the
  // model has no such decoder). Safe to call concurrently.
  at::Tensor encode(const at::Tensor& normalized) const;
  at::Tensor decode(const at::Tensor& codes, DecoderKind kind) const;

  // Writes the model as a folder: manifest.json (shape, normalisation,
  // skeleton, provenance, the trajectory network's shape and training when
  // there is one) and one weights file per network, each written to
  // a temporary file and renamed, manifest last, so a reader never sees a
  // half-written model. `provenance` is free JSON text kept in the manifest.
  void save(const std::string& dir, const std::string& provenance_json = "{}") const;
  // The provenance JSON text of the manifest this model was loaded from
  // ("{}" for a model built in memory).
  const std::string& provenance_json() const { return provenance_json_; }
  // Loads a folder written by save() onto `device`, in eval mode. InputError
  // naming the file for a missing or malformed part.
  static MotionManifold load(const std::string& dir, at::Device device = at::kCPU);

 private:
  void build_tensors();

  ModelConfig config_;
  PoseNormalization normalization_;
  Skeleton skeleton_;
  ForwardKinematics fk_;
  at::Device device_ = at::kCPU;
  std::optional<Precision> inference_precision_;
  Encoder encoder_{nullptr};
  Decoder rotation_decoder_{nullptr}, velocity_decoder_{nullptr};
  Discriminator discriminator_{nullptr};
  RootTrajectory trajectory_{nullptr};
  std::string trajectory_training_json_ = "{}";
  std::string provenance_json_ = "{}";
  // Denormalisation as one affine map: raw = base_ + (x * std + mean) . scatter_
  at::Tensor kept_mean_, kept_std_, base_, scatter_, kept_index_;
};

}  // namespace mm
