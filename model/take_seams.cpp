#include "model/take_seams.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "model/take_processor.h"
#include "model/take_windows.h"

namespace mm {
namespace {

// Joint positions (frames, J, 3) in mm of raw frames at 25 Hz.
at::Tensor positions_of(const MotionManifold& model, const MotionFrames& motion) {
  const auto raw = at::from_blob(const_cast<float*>(motion.values.data()), {motion.frame_count(), motion.columns},
                                 at::kFloat)
                       .clone();
  return model.positions_mm(model.to_normalized(raw)).to(at::kDouble);
}

// Mean over joints of |x|, (frames, J, 3) -> (frames).
at::Tensor mean_joint_norm(const at::Tensor& x) { return x.norm(2, -1).mean(-1); }

// The transitions t -> t + 1 where the cut switches windows: the middle of
// each overlap, as TakeAssembler cuts.
std::vector<int64_t> seam_transitions(const std::vector<int64_t>& starts, int window) {
  std::vector<int64_t> seams;
  for (size_t k = 1; k < starts.size(); ++k) {
    const int64_t overlap_end = starts[k - 1] + window;
    const int64_t middle = starts[k] + (overlap_end - starts[k]) / 2;  // first frame of window k
    seams.push_back(middle - 1);
  }
  return seams;
}

// Transitions at least kSeamMargin frames from every window boundary and seam.
std::vector<int64_t> inside_transitions(const std::vector<int64_t>& starts, const std::vector<int64_t>& seams,
                                        int window, int64_t frames) {
  std::vector<int64_t> marks(seams);
  for (int64_t s : starts) {
    marks.push_back(s);
    marks.push_back(s + window - 1);
  }
  std::vector<int64_t> inside;
  for (int64_t t = 1; t + 2 < frames; ++t) {
    bool near = false;
    for (int64_t m : marks) near = near || std::llabs(t - m) < kSeamMargin;
    if (!near) inside.push_back(t);
  }
  return inside;
}

TransitionStatistics at_transitions(const std::vector<int64_t>& transitions, const at::Tensor& jump,
                                    const at::Tensor& excess, const at::Tensor& jerk, const at::Tensor& input_jump,
                                    const at::Tensor& input_jerk) {
  TransitionStatistics s;
  const int64_t frames = jump.size(0) + 1;
  for (int64_t t : transitions) {
    if (t < 1 || t + 2 >= frames) continue;  // jerk needs t - 1 .. t + 2
    s.jump_mm += jump[t].item<double>();
    s.excess_jump_mm += excess[t].item<double>();
    s.jerk_mm += jerk[t - 1].item<double>();
    s.input_jump_mm += input_jump[t].item<double>();
    s.input_jerk_mm += input_jerk[t - 1].item<double>();
    ++s.transitions;
  }
  if (s.transitions > 0) {
    const double n = static_cast<double>(s.transitions);
    s.jump_mm /= n;
    s.excess_jump_mm /= n;
    s.jerk_mm /= n;
    s.input_jump_mm /= n;
    s.input_jerk_mm /= n;
  }
  return s;
}

BlendSeams measure_blend(const MotionManifold& model, const MotionFrames& take, const at::Tensor& input_positions,
                         double hop_seconds, DecoderKind decoder, TakeBlend blend, const std::vector<int64_t>& seams,
                         const std::vector<int64_t>& inside) {
  TakeOptions options;
  options.operation = TakeOperation::kReconstruct;
  options.frame_rate = kTakeModelRate;
  options.hop_seconds = hop_seconds;
  options.blend = blend;
  options.decoder = decoder;
  const TakeResult result = process_take(model, take, options);
  const at::Tensor p = positions_of(model, result.frames);
  const at::Tensor& q = input_positions;
  const at::Tensor dp = p.slice(0, 1) - p.slice(0, 0, -1);
  const at::Tensor dq = q.slice(0, 1) - q.slice(0, 0, -1);
  const auto third = [](const at::Tensor& x) {
    return x.slice(0, 3) - 3 * x.slice(0, 2, -1) + 3 * x.slice(0, 1, -2) - x.slice(0, 0, -3);
  };
  BlendSeams out;
  out.blend = blend;
  const at::Tensor jump = mean_joint_norm(dp), excess = mean_joint_norm(dp - dq), jerk = mean_joint_norm(third(p));
  const at::Tensor input_jump = mean_joint_norm(dq), input_jerk = mean_joint_norm(third(q));
  out.seams = at_transitions(seams, jump, excess, jerk, input_jump, input_jerk);
  out.inside = at_transitions(inside, jump, excess, jerk, input_jump, input_jerk);
  out.error_mm = result.error_mm;
  out.mean_error_mm = result.summary.mean_error_mm;
  return out;
}

}  // namespace

TakeSeams measure_take_seams(const MotionManifold& model, const MotionFrames& take, const std::string& name,
                             double hop_seconds, DecoderKind decoder) {
  c10::InferenceMode inference;
  const TakeWindowing windowing = take_windowing(model.config().frames, hop_seconds);
  TakeSeams out;
  out.name = name;
  out.frames = take.frame_count();
  out.window_starts = take_window_starts(take.frame_count(), windowing);
  out.windows = static_cast<int>(out.window_starts.size());
  out.hop_seconds = windowing.hop_frames / kTakeModelRate;
  out.seam_transitions = seam_transitions(out.window_starts, windowing.window_frames);
  const std::vector<int64_t>& seams = out.seam_transitions;
  const std::vector<int64_t> inside =
      inside_transitions(out.window_starts, seams, windowing.window_frames, take.frame_count());
  const at::Tensor input_positions = positions_of(model, take);
  out.crossfade = measure_blend(model, take, input_positions, hop_seconds, decoder, TakeBlend::kCrossfade, seams,
                                inside);
  out.cut = measure_blend(model, take, input_positions, hop_seconds, decoder, TakeBlend::kCut, seams, inside);

  // Each window alone, as a single clip: encoded and decoded, its error
  // against the input's frames (joint positions do not depend on the root).
  double error_sum = 0;
  int64_t error_frames = 0;
  for (int64_t start : out.window_starts) {
    MotionFrames clip;
    clip.columns = take.columns;
    clip.values.assign(take.frame(start), take.frame(start) + windowing.window_frames * take.columns);
    const at::Tensor normalized = model.to_normalized(
        at::from_blob(clip.values.data(), {1, windowing.window_frames, clip.columns}, at::kFloat).clone());
    const at::Tensor decoded = model.decode(model.encode(normalized), decoder);
    const at::Tensor error =
        mean_joint_norm(model.positions_mm(decoded)[0].to(at::kDouble) -
                        input_positions.slice(0, start, start + windowing.window_frames));
    error_sum += error.sum().item<double>();
    error_frames += windowing.window_frames;
  }
  out.single_clip_error_mm = error_sum / static_cast<double>(error_frames);
  return out;
}

}  // namespace mm
