// Training of a motion manifold (Sec. 3.3): one iteration updates the
// discriminator (Eq. 16) and then the encoder and decoders (Eq. 15), with
// Adam, global gradient-norm clipping and a stepwise learning-rate decay.
//
// Runs are seeded and reproducible; a checkpoint holds the networks, both
// optimisers, the random states and the iteration, so that a resumed run
// continues exactly as an uninterrupted one.
//
// Thread safety: one thread drives a Trainer; `cancel` may be set from any
// thread (a signal handler too).
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "format/prepared_dataset.h"
#include "model/motion_manifold.h"
#include "model/training_config.h"

namespace mm {

struct Optimizers;
class ClipSampler;

// Loss terms of one iteration by name: L_ang, L_pos, L_R, L_M, L_W, L_G,
// L_D (each already summed over the decoders, before its lambda) and total;
// also D_acc, the discriminator's accuracy on the real and generated clips
// before its update (0 when the variant has no discriminator).
using LossValues = std::map<std::string, double>;

struct TrainProgress {
  int64_t iteration = 0;  // iterations completed
  int64_t total = 0;      // iterations the run is configured for
  LossValues losses;      // of the latest iteration
  double learning_rate = 0;
  double iterations_per_second = 0;
  double eta_seconds = 0;
};
using ProgressCallback = std::function<void(const TrainProgress&)>;

enum class TrainOutcome { kFinished, kCancelled };

class Trainer {
 public:
  // A fresh run. The model's normalisation is the dataset's; its position
  // scale must be set (see position_scale_for). InputError when the dataset
  // and configuration do not fit together.
  Trainer(const TrainConfig& config, const PreparedDataset& data, at::Device device);
  ~Trainer();

  // Continues the run saved in `checkpoint`, on `data` (the same prepared
  // dataset). `iterations`, if positive, replaces the configured total.
  static std::unique_ptr<Trainer> resume(const std::string& checkpoint, const PreparedDataset& data, at::Device device,
                                         int64_t iterations = 0);

  // Starts this fresh run from the weights of an exported model (same network
  // shapes, same dataset normalisation) at `iteration` of the learning-rate
  // schedule, so that a model can be trained on where its checkpoint cannot
  // travel. Not an exact resume: the optimisers' moments are not exported, so
  // Adam starts afresh, and the clip order follows this run's seed. Call
  // before run(). InputError naming the mismatch otherwise.
  void start_from(const MotionManifold& model, int64_t iteration);

  // One iteration on a freshly drawn batch; returns its losses.
  LossValues step();

  // Runs until the configured iterations are done or *cancel becomes true,
  // calling `progress` every log_every iterations and at the end, appending
  // to <output_dir>/train_log.csv and writing <output_dir>/checkpoint.pt
  // every checkpoint_every iterations and at the end (also when cancelled).
  TrainOutcome run(const ProgressCallback& progress, const std::atomic<bool>* cancel = nullptr);

  // Writes a checkpoint atomically (temporary file, then rename).
  void save_checkpoint(const std::string& path) const;

  int64_t iteration() const { return iteration_; }
  const TrainConfig& config() const { return config_; }
  MotionManifold& model() { return *model_; }
  double learning_rate() const;

 private:
  Trainer(const TrainConfig& config, const PreparedDataset& data, at::Device device, bool seed_init);
  void append_log(const LossValues& losses) const;

  TrainConfig config_;
  at::Device device_;
  std::unique_ptr<MotionManifold> model_;
  std::unique_ptr<Optimizers> optimizers_;
  std::unique_ptr<ClipSampler> sampler_;
  at::Generator prior_generator_;
  // For PositionReduction::kStandardizedTripletMean: 1/std per coordinate
  // (J, 3), 0 where dropped, and the joints with a kept coordinate.
  at::Tensor position_inverse_std_, position_counted_joints_;
  // (D,) each normalised value's weight in the angle loss (weights.root_rotation
  // on the root's rotation values); undefined when every weight is 1.
  at::Tensor angle_value_weights_;
  int64_t iteration_ = 0;
};

// The scale of the position loss: the standard deviation of all joint
// coordinates (in mm, about their per-coordinate mean) over the given
// training sequences, one number for every joint. Normalising each
// coordinate separately instead would give joints that barely move (joint 11
// sits 0.1 mm from the root) enormous weight.
double position_scale_for(const PreparedDataset& data, const Skeleton& skeleton);

}  // namespace mm
