#include "model/clip_sampler.h"

#include <algorithm>
#include <cstring>
#include <sstream>

#include "format/input_error.h"

namespace mm {

ClipSampler::ClipSampler(std::vector<const PreparedSequence*> sequences, int frames, uint64_t seed)
    : frames_(frames), engine_(seed) {
  for (const auto* s : sequences) {
    const int64_t starts = s->normalized.frame_count() - frames + 1;
    if (starts <= 0) continue;
    sequences_.push_back(s);
    first_start_.push_back(total_starts_);
    total_starts_ += starts;
  }
  if (sequences_.empty()) {
    throw InputError("dataset", "no sequence has the " + std::to_string(frames) + " frames a clip needs");
  }
}

ClipSampler::Clip ClipSampler::draw() {
  std::uniform_int_distribution<int64_t> pick(0, total_starts_ - 1);
  const int64_t global = pick(engine_);
  const auto it = std::upper_bound(first_start_.begin(), first_start_.end(), global) - 1;
  Clip clip{sequences_[static_cast<size_t>(it - first_start_.begin())], global - *it};
  // Drawn only with a mirror, so that runs without one draw as they did.
  if (mirror_) clip.mirrored = std::bernoulli_distribution(0.5)(engine_);
  return clip;
}

at::Tensor ClipSampler::sample(int batch) {
  std::vector<Clip> clips;
  for (int b = 0; b < batch; ++b) clips.push_back(draw());
  return gather(clips);
}

at::Tensor ClipSampler::gather(const std::vector<Clip>& clips) const {
  const int dims = sequences_.front()->normalized.columns;
  auto out = at::empty({static_cast<int64_t>(clips.size()), frames_, dims});
  float* dst = out.data_ptr<float>();
  for (const auto& clip : clips) {
    const float* src = clip.sequence->normalized.frame(clip.start);
    if (clip.mirrored && mirror_) {
      for (int f = 0; f < frames_; ++f, src += dims, dst += dims) {
        for (int d = 0; d < dims; ++d) {
          dst[d] = mirror_->scale[static_cast<size_t>(d)] * src[mirror_->source_dim[static_cast<size_t>(d)]] +
                   mirror_->shift[static_cast<size_t>(d)];
        }
      }
      continue;
    }
    std::memcpy(dst, src, sizeof(float) * frames_ * dims);
    dst += static_cast<int64_t>(frames_) * dims;
  }
  return out;
}

std::string ClipSampler::state() const {
  std::ostringstream s;
  s << engine_;
  return s.str();
}

void ClipSampler::set_state(const std::string& state) {
  std::istringstream s(state);
  s >> engine_;
  if (!s) throw InputError("checkpoint", "sampler_state: not a random engine state");
}

}  // namespace mm
