// Real H3.6M data for the model tests: subject S1 for training and S5 for
// testing, prepared once per test process (about a second), and tiny model
// configurations that train in seconds on two cores.
#pragma once

#include <memory>

#include "format/prepared_dataset.h"
#include "format/skeleton.h"
#include "model/trainer.h"
#include "model/training_config.h"
#include "tests/common/test_environment.h"

namespace mm::test {

inline const PreparedDataset& small_h36m() {
  static std::unique_ptr<PreparedDataset> data = [] {
    SplitOptions split;
    split.train_subjects = {"S1"};
    split.test_subjects = {"S5"};
    auto prepared = std::make_unique<PreparedDataset>(prepare_h36m(h36m_dataset_dir().string(), split));
    prepared->normalization.position_scale_mm = position_scale_for(*prepared, Skeleton::h36m());
    return prepared;
  }();
  return *data;
}

// DKGM (or another variant) at a size that trains in milliseconds a step.
inline TrainConfig tiny_config(const std::string& variant = "DKGM") {
  TrainConfig c = variant_config(variant);
  c.model.hidden = 48;
  c.model.latent = 8;
  c.model.frames = 30;
  c.batch = 6;
  c.iterations = 10;
  c.log_every = 1;
  c.checkpoint_every = 0;
  c.seed = 7;
  return c;
}

}  // namespace mm::test
