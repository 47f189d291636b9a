#include "model/encoder.h"

#include <c10/core/InferenceMode.h>

#include "model/gru_inference.h"
#include "model/packed_linear.h"

namespace mm {

struct EncoderImpl::Packed {
  PackedLinear input, hidden, to_code;
  bool current() const { return input.current() && hidden.current() && to_code.current(); }
};

void EncoderImpl::pack_for_inference(Precision precision) {
  const auto w = weights();
  packed_.reset(new Packed{PackedLinear(w.weight_ih, w.bias_ih, outside_recurrence(precision)),
                           PackedLinear(w.weight_hh, w.bias_hh, precision),
                           PackedLinear(to_code_->weight, to_code_->bias, outside_recurrence(precision))});
}

EncoderImpl::EncoderImpl(int pose_dims, int hidden, int latent)
    : gru_(register_module("gru", torch::nn::GRU(torch::nn::GRUOptions(pose_dims, hidden).batch_first(true)))),
      to_code_(register_module("to_code", torch::nn::Linear(hidden, latent))) {}

GruWeights EncoderImpl::weights() const {
  auto p = gru_->named_parameters();
  return GruWeights{p["weight_ih_l0"], p["bias_ih_l0"], p["weight_hh_l0"], p["bias_hh_l0"]};
}

at::Tensor EncoderImpl::forward(const at::Tensor& motion) {
  const auto w = weights();
  auto h0 = at::zeros({motion.size(0), w.weight_hh.size(1)}, motion.options());
  return to_code_->forward(gru_last_hidden(motion, h0, w));  // Eq. 1, then W_c
}

at::Tensor EncoderImpl::forward_reference(const at::Tensor& motion) {
  auto last_hidden = std::get<1>(gru_->forward(motion));  // (1, B, hidden)
  return to_code_->forward(last_hidden.squeeze(0));
}

at::Tensor EncoderImpl::encode(const at::Tensor& motion) const {
  c10::InferenceMode inference;
  if (!motion.device().is_cpu() || motion.scalar_type() != at::kFloat) {
    return const_cast<EncoderImpl*>(this)->forward_reference(motion);
  }
  const auto [weight_ih, bias_ih, weight_hh, bias_hh] = weights();
  const int64_t batch = motion.size(0), frames = motion.size(1), hidden_size = weight_hh.size(1);
  if (const auto packed = packed_; packed && packed->current()) {
    // Every frame's input gates in one product, then one per step.
    const auto flat = motion.transpose(0, 1).reshape({frames * batch, -1}).contiguous();
    auto input_gates = at::empty({frames * batch, 3 * hidden_size});
    packed->input.apply(flat, input_gates);
    input_gates = input_gates.view({frames, batch, 3 * hidden_size});
    auto hidden = at::zeros({batch, hidden_size});
    auto hidden_gates = at::empty({batch, 3 * hidden_size});
    for (int64_t t = 0; t < frames; ++t) {
      packed->hidden.apply(hidden, hidden_gates);
      gru_combine(hidden, input_gates.select(0, t), hidden_gates);
    }
    auto code = at::empty({batch, to_code_->weight.size(0)});
    packed->to_code.apply(hidden, code);
    return code;
  }
  // Every frame's input gates in one matrix product: (T, B, 3H).
  auto input_gates = at::addmm(bias_ih, motion.transpose(0, 1).reshape({frames * batch, -1}), weight_ih.t())
                         .view({frames, batch, 3 * hidden_size});
  auto hidden = at::zeros({batch, hidden_size});
  auto hidden_gates = at::empty({batch, 3 * hidden_size});
  for (int64_t t = 0; t < frames; ++t) gru_update(hidden, input_gates.select(0, t), hidden_gates, weight_hh, bias_hh);
  return at::addmm(to_code_->bias, hidden, to_code_->weight.t());
}

}  // namespace mm
