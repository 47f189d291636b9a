#include "model/trainer.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/optim/adam.h>
#include <torch/serialize/input-archive.h>
#include <torch/serialize/output-archive.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <sstream>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "model/clip_sampler.h"
#include "model/losses.h"
#include "model/paper_units.h"

namespace mm {

struct Optimizers {
  torch::optim::Adam generator;
  torch::optim::Adam discriminator;
};

namespace {

constexpr const char* kCheckpointFormat = "motion-manifold-checkpoint-1";
const char* const kLogColumns[] = {"L_ang", "L_pos", "L_R", "L_M", "L_W", "L_G", "L_D", "D_acc", "total"};

void set_learning_rate(torch::optim::Optimizer& optimizer, double lr) {
  for (auto& group : optimizer.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
}

std::string read_string(torch::serialize::InputArchive& archive, const std::string& key, const std::string& path) {
  c10::IValue value;
  if (!archive.try_read(key, value) || !value.isString()) throw InputError(path + ": checkpoint has no " + key);
  return value.toStringRef();
}

// Scales the gradients so that their global L2 norm is at most max_norm, as
// torch::nn::utils::clip_grad_norm_ does, without reading the norm back to
// the host: on a GPU that read would wait for the whole backward pass.
void clip_gradient_norm(const std::vector<at::Tensor>& parameters, double max_norm) {
  std::vector<at::Tensor> norms;
  for (const auto& p : parameters) {
    if (p.grad().defined()) norms.push_back(p.grad().norm());
  }
  if (norms.empty()) return;
  const auto scale = (max_norm / (at::stack(norms).norm() + 1e-6)).clamp_max(1.0);
  for (const auto& p : parameters) {
    if (p.grad().defined()) p.grad().mul_(scale);
  }
}

}  // namespace

double position_scale_for(const PreparedDataset& data, const Skeleton& skeleton) {
  ForwardKinematics fk(skeleton);
  const auto& norm = data.normalization;
  // Every 5th frame of the training set is plenty for one scalar.
  constexpr int kStride = 5;
  std::vector<float> raw;
  for (const auto* s : data.subset(data.train_subjects)) {
    for (int64_t f = 0; f < s->normalized.frame_count(); f += kStride) {
      raw.resize(raw.size() + norm.input_columns());
      norm.denormalize(s->normalized.frame(f), raw.data() + raw.size() - norm.input_columns());
  }
  }
  if (raw.empty()) throw InputError("dataset", "no training frames to measure the position scale on");
  const int64_t n = static_cast<int64_t>(raw.size()) / norm.input_columns();
  auto frames = at::from_blob(raw.data(), {n, norm.input_columns()}).to(at::kDouble);
  auto positions = fk.positions(frames).reshape({n, -1});
  auto centred = positions - positions.mean(0, true);
  return std::sqrt(centred.pow(2).mean().item<double>());
}

Trainer::Trainer(const TrainConfig& config, const PreparedDataset& data, at::Device device)
    : Trainer(config, data, device, true) {}

Trainer::~Trainer() = default;

Trainer::Trainer(const TrainConfig& config, const PreparedDataset& data, at::Device device, bool seed_init)
    : config_(config), device_(device), prior_generator_(at::detail::createCPUGenerator(config.seed + 1)) {
  if (data.normalization.dims() != config_.model.pose_dims) {
    throw InputError("model.pose_dims", std::to_string(config_.model.pose_dims) + " does not match the dataset's " +
                     std::to_string(data.normalization.dims()) + " pose dimensions");
  }
  if (seed_init) torch::manual_seed(config_.seed);
  model_ = std::make_unique<MotionManifold>(config_.model, data.normalization, data.skeleton);
  model_->to(device_);
  model_->train(true);
  const auto adam = torch::optim::AdamOptions(config_.learning_rate);
  optimizers_.reset(new Optimizers{torch::optim::Adam(model_->generator_parameters(), adam),
                                   torch::optim::Adam(model_->discriminator()->parameters(), adam)});
  sampler_ = std::make_unique<ClipSampler>(data.subset(data.train_subjects), config_.model.frames, config_.seed);
  if (config_.mirror) {
    try {
      sampler_->set_mirror(normalized_mirror(motion_mirror(data.skeleton), data.normalization));
    } catch (const InputError& error) {
      throw InputError("mirror", std::string("true, but the dataset's motions have no mirror image: ") + error.what());
    }
  }
  if (config_.weights.position > 0 && config_.losses.position == PositionReduction::kStandardizedTripletMean) {
    // The statistics follow from the dataset, so a resumed run fits the same.
    const auto standardization = fit_position_standardization(*model_, data.subset(data.train_subjects));
    const auto kept = standardization.kept.reshape({-1, 3});
    position_inverse_std_ = at::where(kept, 1.0 / standardization.stddev.reshape({-1, 3}), at::zeros_like(kept, at::kDouble))
                                .to(at::kFloat)
                                .to(device_);
    position_counted_joints_ = kept.any(-1).nonzero().flatten().to(device_);
  }
  if (config_.weights.root_rotation != 1.0) {
    // Columns 3..5 are the root's rotation in every layout (H3.6M's and a
    // rig's exp-map layout alike, format/skeleton_bvh.h).
    std::vector<float> weights(data.normalization.kept_columns.size(), 1.0f);
    for (size_t d = 0; d < weights.size(); ++d) {
      const int column = data.normalization.kept_columns[d];
      if (column >= 3 && column < 6) weights[d] = static_cast<float>(config_.weights.root_rotation);
    }
    angle_value_weights_ = at::tensor(weights).to(device_);
  }
}

double Trainer::learning_rate() const {
  return config_.learning_rate * std::pow(config_.lr_decay, static_cast<double>(iteration_ / config_.decay_every));
}

LossValues Trainer::step() {
  const auto& w = config_.weights;
  const double lr = learning_rate();
  set_learning_rate(optimizers_->generator, lr);
  set_learning_rate(optimizers_->discriminator, lr);
  model_->train(true);

  auto motion = sampler_->sample(config_.batch).to(device_);
  auto code = model_->encoder()->forward(motion);
  // Both decoders as one recurrence: half the decoders' kernel launches,
  // which bound the step on a GPU (on the CPU it costs about the same).
  std::vector<DecoderImpl*> decoders;
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    if (model_->has_decoder(kind)) decoders.push_back(model_->decoder(kind).get());
  }
  const std::vector<at::Tensor> decoded = forward_together(decoders, code);
  at::Tensor loss_d_value = at::zeros({}, motion.options());
  at::Tensor accuracy_d = at::zeros({}, motion.options());

  // Discriminator first (Eq. 16), on the generator's current output.
  if (w.adversarial > 0) {
    auto& d = model_->discriminator();
    auto fake = at::cat(decoded, 0).detach();
    // The reference runs one discriminator loss per decoder, each with the
    // real clips; the paper's Eq. 16 counts the real clips once.
    const double real_weight =
        config_.losses.adversarial == AdversarialReduction::kBatchSum ? static_cast<double>(decoded.size()) : 1.0;
    const auto real_scores = d->step_scores(motion);
    const auto fake_scores = d->step_scores(fake);
    auto loss_d = lsgan_discriminator_loss(real_scores, fake_scores, config_.losses.adversarial, real_weight);
    // How often the discriminator tells the clips apart before its update (a
    // clip's score is its mean over the steps; LSGAN's targets are 1 and 0):
    // near 1 it wins outright and its gradient to the generator says little.
    accuracy_d = (real_scores.detach().mean(1).gt(0.5).sum() + fake_scores.detach().mean(1).lt(0.5).sum())
                     .to(motion.scalar_type()) /
                 static_cast<double>(real_scores.size(0) + fake_scores.size(0));
    optimizers_->discriminator.zero_grad();
    (w.adversarial * loss_d).backward();
    optimizers_->discriminator.step();
    loss_d_value = loss_d.detach();
  }

  // Generator (Eq. 15): every term summed over the decoders.
  auto zero = at::zeros({}, motion.options());
  auto l_ang = zero, l_pos = zero, l_m = zero, l_g = zero, l_w = zero;
  // A weight on some values scales their difference: both sides alike.
  const auto weighted = [this](const at::Tensor& q) {
    return angle_value_weights_.defined() ? q * angle_value_weights_ : q;
  };
  for (const auto& q_hat : decoded) l_ang = l_ang + angle_loss(weighted(q_hat), weighted(motion), config_.losses.angle);
  if (w.position > 0) {
    // The truth and every decoder's output through FK as one batch: FK is
    // 32 dependent joint steps, so one pass instead of three saves launches.
    std::vector<at::Tensor> clips{motion};
    clips.insert(clips.end(), decoded.begin(), decoded.end());
    if (config_.losses.position == PositionReduction::kStandardizedTripletMean) {
      const auto positions = model_->positions_mm(at::cat(clips, 0)).split(config_.batch, 0);
      for (size_t i = 1; i < positions.size(); ++i) {
        l_pos = l_pos + position_loss_standardized(positions[i], positions[0], position_inverse_std_,
                                                   position_counted_joints_);
      }
    } else {
      const auto positions = model_->positions_scaled(at::cat(clips, 0)).split(config_.batch, 0);
      const bool joint_sum = config_.losses.position == PositionReduction::kJointSum;
      for (size_t i = 1; i < positions.size(); ++i) {
        l_pos = l_pos + (joint_sum ? position_loss_joint_sum(positions[i], positions[0])
                                   : position_loss(positions[i], positions[0]));
      }
    }
  }
  // Both decoders' outputs go through the encoder and the discriminator as
  // one batch: one recurrence instead of two, and the discriminator sees the
  // same batch composition as in its own update.
  const auto decoder_count = static_cast<double>(decoded.size());
  if (w.manifold > 0) {
    auto recoded = model_->encoder()->forward(at::cat(decoded, 0));
    l_m = decoder_count * manifold_loss(recoded, code.repeat({static_cast<int64_t>(decoded.size()), 1}));
  }
  if (w.adversarial > 0) {
    const auto scores = model_->discriminator()->step_scores(at::cat(decoded, 0));
    // Half-mean is a mean over the concatenated clips: times the decoder
    // count it is each decoder's term summed, as Eq. 15 sums them. The sums
    // over the concatenated clips already are.
    l_g = config_.losses.adversarial == AdversarialReduction::kHalfMean
              ? decoder_count * lsgan_generator_loss(scores, config_.losses.adversarial)
              : lsgan_generator_loss(scores, config_.losses.adversarial);
  }
  if (w.wasserstein > 0) {
    auto prior = at::randn({config_.batch, config_.model.latent}, prior_generator_).to(device_) *
                 std::sqrt(w.prior_variance);
    l_w = mmd(code, prior, w.prior_variance, config_.losses.mmd);
  }
  auto l_r = l_ang + w.position * l_pos;  // Eq. 8
  auto total = l_r + w.manifold * l_m + w.wasserstein * l_w + w.adversarial * l_g;
  optimizers_->generator.zero_grad();
  total.backward();
  if (config_.clip_norm > 0) clip_gradient_norm(model_->generator_parameters(), config_.clip_norm);
  optimizers_->generator.step();
  ++iteration_;

  // One transfer for all values: on a GPU each read waits for the device.
  const std::vector<std::pair<const char*, at::Tensor>> terms = {
      {"L_ang", l_ang}, {"L_pos", l_pos}, {"L_R", l_r}, {"L_M", l_m}, {"L_W", l_w},
      {"L_G", l_g},     {"L_D", loss_d_value}, {"D_acc", accuracy_d}, {"total", total}};
  std::vector<at::Tensor> values;
  for (const auto& term : terms) values.push_back(term.second.detach().reshape({}).to(at::kDouble));
  const auto host = at::stack(values).to(at::kCPU);
  LossValues losses;
  for (size_t i = 0; i < terms.size(); ++i) losses[terms[i].first] = host[static_cast<int64_t>(i)].item<double>();
  return losses;
}

TrainOutcome Trainer::run(const ProgressCallback& progress, const std::atomic<bool>* cancel) {
  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  const int64_t first = iteration_;
  const bool has_output = !config_.output_dir.empty();
  if (has_output) std::filesystem::create_directories(config_.output_dir);
  const std::string checkpoint = config_.output_dir + "/checkpoint.pt";
  TrainOutcome outcome = TrainOutcome::kFinished;
  LossValues losses;
  auto report = [&] {
    TrainProgress p;
    p.iteration = iteration_;
    p.total = config_.iterations;
    p.losses = losses;
    p.learning_rate = learning_rate();
    const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
    p.iterations_per_second = seconds > 0 ? static_cast<double>(iteration_ - first) / seconds : 0;
    p.eta_seconds = p.iterations_per_second > 0
                        ? static_cast<double>(config_.iterations - iteration_) / p.iterations_per_second
                        : 0;
    if (progress) progress(p);
  };
  while (iteration_ < config_.iterations) {
    if (cancel && cancel->load()) {
      outcome = TrainOutcome::kCancelled;
      break;
  }
    losses = step();
    if (iteration_ % config_.log_every == 0) {
      if (has_output) append_log(losses);
      report();
  }
    if (has_output && config_.checkpoint_every > 0 && iteration_ % config_.checkpoint_every == 0) {
      save_checkpoint(checkpoint);
  }
  }
  if (!losses.empty() && iteration_ % config_.log_every != 0) {  // the last iteration is always logged
    if (has_output) append_log(losses);
    report();
  }
  // A run resumed from a checkpoint of its last iteration steps no more, but
  // still says where it stands (the service's record of a job depends on it).
  if (iteration_ == first) report();
  if (has_output) save_checkpoint(checkpoint);
  return outcome;
}

void Trainer::append_log(const LossValues& losses) const {
  const std::string path = config_.output_dir + "/train_log.csv";
  const bool fresh = !std::filesystem::exists(path);
  std::ofstream out(path, std::ios::app);
  if (fresh) {
    out << "iteration,learning_rate";
    for (const char* c : kLogColumns) out << ',' << c;
    out << '\n';
  }
  out << iteration_ << ',' << learning_rate();
  for (const char* c : kLogColumns) out << ',' << losses.at(c);
  out << '\n';
}

void Trainer::save_checkpoint(const std::string& path) const {
  torch::serialize::OutputArchive archive;
  archive.write("format", c10::IValue(std::string(kCheckpointFormat)));
  archive.write("config", c10::IValue(to_json_text(config_)));
  archive.write("normalization", c10::IValue(model_->normalization().to_json_text()));
  archive.write("skeleton", c10::IValue(model_->skeleton().to_json_text()));
  archive.write("iteration", c10::IValue(iteration_));
  archive.write("sampler_state", c10::IValue(sampler_->state()));
  archive.write("prior_generator_state", prior_generator_.get_state());
  auto nested = [&](const char* key, const auto& saveable) {
    torch::serialize::OutputArchive sub;
    saveable.save(sub);
    archive.write(key, sub);
  };
  nested("encoder", *model_->encoder());
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    if (model_->has_decoder(kind)) nested((std::string(decoder_name(kind)) + "_decoder").c_str(), *model_->decoder(kind));
  }
  nested("discriminator", *model_->discriminator());
  nested("optimizer_generator", optimizers_->generator);
  nested("optimizer_discriminator", optimizers_->discriminator);
  std::ostringstream bytes;
  archive.save_to(bytes);
  write_file_atomically(path, bytes.str());
}

void Trainer::start_from(const MotionManifold& model, int64_t iteration) {
  const auto &want = config_.model, &have = model.config();
  auto check = [](const char* field, int64_t expected, int64_t found) {
    if (expected != found) {
      throw InputError(std::string("model.") + field + ": the run is configured for " + std::to_string(expected) +
                       ", the starting model has " + std::to_string(found));
    }
  };
  check("pose_dims", want.pose_dims, have.pose_dims);
  check("hidden", want.hidden, have.hidden);
  check("latent", want.latent, have.latent);
  check("frames", want.frames, have.frames);
  check("rotation_decoder", want.rotation_decoder, have.rotation_decoder);
  check("velocity_decoder", want.velocity_decoder, have.velocity_decoder);
  check("feed_code", want.feed_code, have.feed_code);
  if (model.normalization().to_json_text() != model_->normalization().to_json_text()) {
    throw InputError("normalization", "the starting model was trained on a differently prepared dataset");
  }
  if (iteration < 0 || iteration >= config_.iterations) {
    throw InputError("iteration", "expected 0 to " + std::to_string(config_.iterations - 1) + " (the run's iterations), found " +
                     std::to_string(iteration));
  }
  auto copy = [](const torch::nn::Module& from, torch::nn::Module& to) {
    torch::NoGradGuard no_grad;
    const auto source = from.named_parameters();
    for (auto& p : to.named_parameters()) p.value().copy_(source[p.key()]);
  };
  copy(*model.encoder(), *model_->encoder());
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    if (model_->has_decoder(kind)) copy(*model.decoder(kind), *model_->decoder(kind));
  }
  copy(*model.discriminator(), *model_->discriminator());
  iteration_ = iteration;
}

std::unique_ptr<Trainer> Trainer::resume(const std::string& path, const PreparedDataset& data, at::Device device,
                                         int64_t iterations) {
  if (!std::filesystem::exists(path)) throw InputError(path + ": checkpoint not found");
  torch::serialize::InputArchive archive;
  try {
    archive.load_from(path, device);
  } catch (const c10::Error& e) {
    throw InputError(path + ": not a readable checkpoint: " + e.what_without_backtrace());
  }
  if (read_string(archive, "format", path) != kCheckpointFormat) {
    throw InputError(path + ": format: expected " + std::string(kCheckpointFormat));
  }
  TrainConfig config = train_config_from_json_text(read_string(archive, "config", path), path + ": config");
  if (iterations > 0) config.iterations = iterations;
  if (read_string(archive, "normalization", path) != data.normalization.to_json_text()) {
    throw InputError(path + ": the checkpoint was trained on a differently prepared dataset");
  }
  std::unique_ptr<Trainer> trainer(new Trainer(config, data, device, false));
  auto nested = [&](const char* key, auto& loadable) {
    torch::serialize::InputArchive sub;
    if (!archive.try_read(key, sub)) throw InputError(path + ": checkpoint has no " + key);
    loadable.load(sub);
  };
  try {
    nested("encoder", *trainer->model_->encoder());
    for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
      if (trainer->model_->has_decoder(kind)) {
        nested((std::string(decoder_name(kind)) + "_decoder").c_str(), *trainer->model_->decoder(kind));
      }
    }
    nested("discriminator", *trainer->model_->discriminator());
    nested("optimizer_generator", trainer->optimizers_->generator);
    nested("optimizer_discriminator", trainer->optimizers_->discriminator);
    c10::IValue iteration;
    archive.read("iteration", iteration);
    trainer->iteration_ = iteration.toInt();
    at::Tensor state;
    archive.read("prior_generator_state", state);
    trainer->prior_generator_.set_state(state.cpu());
  } catch (const c10::Error& e) {
    throw InputError(path + ": damaged checkpoint: " + e.what_without_backtrace());
  }
  trainer->sampler_->set_state(read_string(archive, "sampler_state", path));
  trainer->model_->to(device);
  return trainer;
}

}  // namespace mm
