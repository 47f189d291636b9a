#include "model/synthetic_dataset.h"

#include <random>
#include <vector>

namespace mm {
namespace {

// The 51 columns of the 99 H3.6M exponential-map values that vary in the
// data (std >= 1e-4, root translation excluded): what prepare keeps.
const std::vector<int> kH36mKeptColumns = {3,  4,  5,  6,  7,  8,  9,  12, 13, 14, 15, 21, 22, 23, 24, 27, 28,
                                           29, 30, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 51, 52, 53,
                                           54, 55, 56, 57, 60, 61, 62, 75, 76, 77, 78, 79, 80, 81, 84, 85, 86};

}  // namespace

PreparedDataset synthetic_h36m_dataset(unsigned seed) {
  PreparedDataset data;
  auto& norm = data.normalization;
  norm.mean.assign(kH36mColumns, 0.0f);
  norm.stddev.assign(kH36mColumns, 1.0f);
  norm.kept_columns = kH36mKeptColumns;
  norm.position_scale_mm = 400;
  data.train_subjects = {"S1"};
  data.test_subjects = {"S5"};
  std::mt19937 engine(seed);
  std::normal_distribution<float> normal;
  for (int i = 0; i < 4; ++i) {
    PreparedSequence s;
    s.subject = "S1";
    s.action = "synthetic";
    s.take = 1;
    s.phase = i;
    s.normalized.columns = norm.dims();
    s.normalized.values.resize(static_cast<size_t>(600) * norm.dims());
    for (auto& v : s.normalized.values) v = normal(engine);
    data.sequences.push_back(std::move(s));
  }
  return data;
}

}  // namespace mm
