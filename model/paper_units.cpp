#include "model/paper_units.h"

#include <c10/core/InferenceMode.h>

#include <algorithm>
#include <string>

#include "format/input_error.h"

namespace mm {

at::Tensor mean_triplet_norm(const at::Tensor& difference) {
  const int64_t values = difference.size(-1);
  if (values % 3 != 0) {
    throw InputError("difference", "expected a last dimension that is a multiple of 3 (triplets), found " +
                     std::to_string(values));
  }
  auto sizes = difference.sizes().vec();
  sizes.back() = values / 3;
  sizes.push_back(3);
  return difference.reshape(sizes).norm(2, -1).mean(-1);
}

CoordinateStandardization CoordinateStandardization::fit(const at::Tensor& coordinates, double min_std) {
  if (coordinates.dim() != 2 || coordinates.size(0) == 0 || coordinates.size(1) % 3 != 0) {
    throw InputError("coordinates", "expected (frames > 0, 3 x joints), found shape " + c10::str(coordinates.sizes()));
  }
  CoordinateStandardization s;
  const auto x = coordinates.to(at::kDouble);
  s.frames = x.size(0);
  s.mean = x.mean(0);
  s.stddev = x.std(0, /*unbiased=*/false);
  s.kept = s.stddev >= min_std;
  if (!s.kept.any().item<bool>()) {
    throw InputError("coordinates", "none has a std >= " + std::to_string(min_std) + " over the frames");
  }
  return s;
}

int64_t CoordinateStandardization::kept_count() const { return kept.sum().item<int64_t>(); }

at::Tensor CoordinateStandardization::apply(const at::Tensor& coordinates) const {
  const auto device = coordinates.device();
  const auto standardized = (coordinates.to(at::kDouble) - mean.to(device)) / stddev.to(device);
  return standardized.masked_fill(kept.to(device).logical_not(), 0.0);
}

CoordinateStandardization fit_position_standardization(const MotionManifold& model,
                                                       const std::vector<const PreparedSequence*>& sequences) {
  c10::InferenceMode inference;
  const int64_t dims = model.normalization().dims();
  // Chunks of whole sequences keep FK's intermediate tensors small.
  constexpr int64_t kChunkFrames = 20000;
  std::vector<at::Tensor> positions;
  std::vector<float> chunk;
  auto flush = [&] {
    if (chunk.empty()) return;
    const int64_t frames = static_cast<int64_t>(chunk.size()) / dims;
    const auto normalized = at::from_blob(chunk.data(), {frames, dims}, at::kFloat).to(model.device());
    positions.push_back(model.positions_mm(normalized).reshape({frames, -1}).to(at::kDouble).cpu());
    chunk.clear();
  };
  for (const auto* sequence : sequences) {
    if (sequence->normalized.columns != dims) {
      throw InputError(sequence->subject + " " + sequence->action + ": expected " + std::to_string(dims) +
                       " normalised values per frame, found " + std::to_string(sequence->normalized.columns));
    }
    chunk.insert(chunk.end(), sequence->normalized.values.begin(), sequence->normalized.values.end());
    if (static_cast<int64_t>(chunk.size()) / dims >= kChunkFrames) flush();
  }
  flush();
  if (positions.empty()) throw InputError("sequences", "expected training frames to fit the position statistics, found none");
  return CoordinateStandardization::fit(at::cat(positions));
}

at::Tensor paper_angle_error(const at::Tensor& q_hat, const at::Tensor& q) { return mean_triplet_norm(q_hat - q); }

at::Tensor paper_position_error(const CoordinateStandardization& standardization, const at::Tensor& p_hat_mm,
                                const at::Tensor& p_mm) {
  auto flat = [](const at::Tensor& p) { return p.flatten(-2, -1); };
  const auto difference = standardization.apply(flat(p_hat_mm)) - standardization.apply(flat(p_mm));
  // Dropped coordinates are zero: the norm of a joint is that of its kept
  // coordinates, and the mean runs over the joints with any kept.
  const auto joint_norms = difference.reshape({-1, difference.size(-1) / 3, 3}).norm(2, -1);
  const auto counted = standardization.kept.reshape({-1, 3}).any(-1).to(difference.device());
  const auto mean = joint_norms.index_select(-1, counted.nonzero().flatten()).mean(-1);
  auto sizes = p_mm.sizes().vec();
  sizes.resize(sizes.size() - 2);
  return mean.reshape(sizes);
}

}  // namespace mm
