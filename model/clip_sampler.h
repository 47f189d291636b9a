// Draws random fixed-length clips from prepared sequences for training:
// every start frame of every sequence equally likely (Sec. 4).
//
// Thread safety: not safe for concurrent use (it owns a random engine).
#pragma once

#include <ATen/ATen.h>

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "format/motion_mirror.h"
#include "format/prepared_dataset.h"

namespace mm {

class ClipSampler {
 public:
  // Sequences shorter than `frames` are skipped; InputError if none is long
  // enough. The sequences must outlive the sampler.
  ClipSampler(std::vector<const PreparedSequence*> sequences, int frames, uint64_t seed);

  struct Clip {
    const PreparedSequence* sequence;
    int64_t start;  // first frame
    bool mirrored = false;  // gathered as its mirror image
  };
  // One clip, uniformly over all (sequence, start) pairs; with a mirror
  // set, mirrored with probability 1/2.
  Clip draw();

  // From now on, half the clips drawn are mirrored by `mirror` (the
  // sequences' normalised frames' map, format/motion_mirror.h).
  void set_mirror(NormalizedMirror mirror) { mirror_ = std::move(mirror); }

  // (batch, frames, dims) normalised poses on the CPU.
  at::Tensor sample(int batch);
  // The frames of the given clips as one (clips, frames, dims) tensor.
  at::Tensor gather(const std::vector<Clip>& clips) const;

  // The random engine's state, so that a resumed run draws the same clips.
  std::string state() const;
  void set_state(const std::string& state);

  int64_t clip_count() const { return total_starts_; }

 private:
  std::vector<const PreparedSequence*> sequences_;
  std::vector<int64_t> first_start_;  // running count of start frames before each sequence
  int64_t total_starts_ = 0;
  int frames_;
  std::mt19937_64 engine_;
  std::optional<NormalizedMirror> mirror_;
};

}  // namespace mm
