#include "gru_recurrence.h"

#include <torch/csrc/autograd/custom_function.h>

namespace mm {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// Activations of one GRU step that its backward pass needs.
struct StepCache {
  at::Tensor reset, update, candidate, hidden_n;  // r, z, n and the (W_hn h + b_hn) term, each (B, H)
};

// h' = (1 - z) n + z h, writing the activations into the `cache` slots
// (views into per-sequence buffers).
at::Tensor gru_step(const at::Tensor& input_gates, const at::Tensor& hidden_gates, const at::Tensor& hidden,
                    StepCache cache) {
  auto gi = input_gates.chunk(3, 1), gh = hidden_gates.chunk(3, 1);
  at::sigmoid_out(cache.reset, gi[0] + gh[0]);
  at::sigmoid_out(cache.update, gi[1] + gh[1]);
  cache.hidden_n.copy_(gh[2]);
  at::tanh_out(cache.candidate, gi[2] + cache.reset * gh[2]);
  return cache.candidate + cache.update * (hidden - cache.candidate);
}

// Given dL/dh' of one step, returns dL/dh (through the gates too) and writes
// the gradients of the input and hidden gate pre-activations.
at::Tensor gru_step_backward(const at::Tensor& grad_hidden, const at::Tensor& hidden, const StepCache& c,
                             const at::Tensor& weight_hh, at::Tensor grad_input_gates, at::Tensor grad_hidden_gates) {
  auto grad_candidate = grad_hidden * (1 - c.update) * (1 - c.candidate * c.candidate);
  auto grad_update = grad_hidden * (hidden - c.candidate) * c.update * (1 - c.update);
  auto grad_reset = grad_candidate * c.hidden_n * c.reset * (1 - c.reset);
  const int64_t h = hidden.size(1);
  grad_input_gates.narrow(1, 0, h).copy_(grad_reset);
  grad_input_gates.narrow(1, h, h).copy_(grad_update);
  grad_input_gates.narrow(1, 2 * h, h).copy_(grad_candidate);
  grad_hidden_gates.narrow(1, 0, 2 * h).copy_(grad_input_gates.narrow(1, 0, 2 * h));
  grad_hidden_gates.narrow(1, 2 * h, h).copy_(grad_candidate * c.reset);
  return grad_hidden * c.update + at::mm(grad_hidden_gates, weight_hh);
}

// Everything a recurrence's backward pass reads: the step inputs, the hidden
// states h_0 .. h_T and each step's activations.
struct SequenceState {
  at::Tensor inputs;                 // (T, B, I)
  at::Tensor hiddens;                // (T + 1, B, H)
  at::Tensor reset, update, candidate, hidden_n;  // (T, B, H) each

  SequenceState(at::Tensor step_inputs, int64_t batch, int64_t size, const at::TensorOptions& options)
      : inputs(std::move(step_inputs)) {
    const int64_t frames = inputs.size(0);
    hiddens = at::empty({frames + 1, batch, size}, options);
    reset = at::empty({frames, batch, size}, options);
    update = at::empty_like(reset);
    candidate = at::empty_like(reset);
    hidden_n = at::empty_like(reset);
  }
  explicit SequenceState(AutogradContext* ctx)
      : inputs(ctx->saved_data["inputs"].toTensor()),
        hiddens(ctx->saved_data["hiddens"].toTensor()),
        reset(ctx->saved_data["reset"].toTensor()),
        update(ctx->saved_data["update"].toTensor()),
        candidate(ctx->saved_data["candidate"].toTensor()),
        hidden_n(ctx->saved_data["hidden_n"].toTensor()) {}

  void save(AutogradContext* ctx) const {
    ctx->saved_data["inputs"] = inputs;
    ctx->saved_data["hiddens"] = hiddens;
    ctx->saved_data["reset"] = reset;
    ctx->saved_data["update"] = update;
    ctx->saved_data["candidate"] = candidate;
    ctx->saved_data["hidden_n"] = hidden_n;
  }
  int64_t frames() const { return inputs.size(0); }
  StepCache step(int64_t t) const { return StepCache{reset[t], update[t], candidate[t], hidden_n[t]}; }
  // h_0 .. h_{T-1}: what each step's hidden gates were computed from.
  at::Tensor previous_hiddens() const { return hiddens.narrow(0, 0, frames()); }
};

// Sum over the first two dimensions and the (3H x K) weight gradient
// sum_t grad_gates[t]^T . inputs[t], each as one product.
std::pair<at::Tensor, at::Tensor> weight_and_bias_grad(const at::Tensor& grad_gates, const at::Tensor& inputs) {
  auto g = grad_gates.reshape({-1, grad_gates.size(-1)});
  return {at::mm(g.t(), inputs.reshape({-1, inputs.size(-1)})), g.sum(0)};
}

struct LastHidden : public torch::autograd::Function<LastHidden> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& inputs, const at::Tensor& h0,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh) {
    const int64_t batch = inputs.size(0), frames = inputs.size(1), size = weight_hh.size(1);
    auto time_major = inputs.transpose(0, 1).contiguous();  // (T, B, I)
    auto input_gates = at::addmm(bias_ih, time_major.view({frames * batch, -1}), weight_ih.t()).view({frames, batch, -1});
    SequenceState state(time_major, batch, size, h0.options());
    auto& hiddens = state.hiddens;
    hiddens[0].copy_(h0);
    for (int64_t t = 0; t < frames; ++t) {
      auto hidden_gates = at::addmm(bias_hh, hiddens[t], weight_hh.t());
      hiddens[t + 1].copy_(gru_step(input_gates[t], hidden_gates, hiddens[t], state.step(t)));
    }
    ctx->save_for_backward({weight_ih, weight_hh});
    state.save(ctx);
    return hiddens[frames].clone();
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto &weight_ih = saved[0], &weight_hh = saved[1];
    const SequenceState state(ctx);
    const auto& hiddens = state.hiddens;
    const int64_t frames = state.frames(), batch = state.inputs.size(1), size = weight_hh.size(1);
    auto grad_input_gates = at::empty({frames, batch, 3 * size}, hiddens.options());
    auto grad_hidden_gates = at::empty_like(grad_input_gates);
    auto grad_hidden = grad_outputs[0].defined() ? grad_outputs[0] : at::zeros({batch, size}, hiddens.options());
    for (int64_t t = frames - 1; t >= 0; --t) {
      grad_hidden = gru_step_backward(grad_hidden, hiddens[t], state.step(t), weight_hh, grad_input_gates[t],
                                      grad_hidden_gates[t]);
    }
    auto grad_inputs = at::matmul(grad_input_gates, weight_ih).transpose(0, 1);
    auto [grad_weight_ih, grad_bias_ih] = weight_and_bias_grad(grad_input_gates, state.inputs);
    auto [grad_weight_hh, grad_bias_hh] = weight_and_bias_grad(grad_hidden_gates, state.previous_hiddens());
    return {grad_inputs, grad_hidden, grad_weight_ih, grad_bias_ih, grad_weight_hh, grad_bias_hh};
  }
};

struct Autoregressive : public torch::autograd::Function<Autoregressive> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& h0, const at::Tensor& code,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh, const at::Tensor& weight_out, const at::Tensor& bias_out,
                            int64_t frames, bool residual, bool feed_code) {
    const int64_t batch = h0.size(0), size = weight_hh.size(1), dims = weight_out.size(0);
    const int64_t input_size = weight_ih.size(1);
    auto opts = h0.options();
    auto inputs = at::zeros({frames, batch, input_size}, opts);  // step t's input; step 0 sees a zero pose
    if (feed_code) inputs.narrow(2, dims, input_size - dims).copy_(code.unsqueeze(0).expand({frames, batch, -1}));
    SequenceState state(inputs, batch, size, opts);
    auto& hiddens = state.hiddens;
    auto outputs = at::empty({frames, batch, dims}, opts);
    hiddens[0].copy_(h0);
    for (int64_t t = 0; t < frames; ++t) {
      auto input_gates = at::addmm(bias_ih, inputs[t], weight_ih.t());
      auto hidden_gates = at::addmm(bias_hh, hiddens[t], weight_hh.t());
      hiddens[t + 1].copy_(gru_step(input_gates, hidden_gates, hiddens[t], state.step(t)));
      auto pose = at::addmm(bias_out, hiddens[t + 1], weight_out.t());
      if (residual && t > 0) pose.add_(outputs[t - 1]);
      outputs[t].copy_(pose);
      if (t + 1 < frames) inputs[t + 1].narrow(1, 0, dims).copy_(pose);
    }
    ctx->save_for_backward({weight_ih, weight_hh, weight_out});
    state.save(ctx);
    ctx->saved_data["residual"] = residual;
    ctx->saved_data["feed_code"] = feed_code;
    return outputs;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto &weight_ih = saved[0], &weight_hh = saved[1], &weight_out = saved[2];
    const SequenceState state(ctx);
    const auto& hiddens = state.hiddens;
    const bool residual = ctx->saved_data["residual"].toBool(), feed_code = ctx->saved_data["feed_code"].toBool();
    const int64_t frames = state.frames(), batch = state.inputs.size(1), size = weight_hh.size(1);
    const int64_t dims = weight_out.size(0);
    auto opts = hiddens.options();
    auto grad_poses = grad_outputs[0].defined() ? grad_outputs[0] : at::zeros({frames, batch, dims}, opts);
    auto grad_input_gates = at::empty({frames, batch, 3 * size}, opts);
    auto grad_hidden_gates = at::empty_like(grad_input_gates);
    auto grad_outputs_total = at::empty({frames, batch, dims}, opts);  // dL/dy_t through every path
    auto grad_hidden = at::zeros({batch, size}, opts);
    auto grad_from_future = at::zeros({batch, dims}, opts);  // into y_t from step t+1's input and residual
    for (int64_t t = frames - 1; t >= 0; --t) {
      auto grad_pose = grad_poses[t] + grad_from_future;
      grad_outputs_total[t].copy_(grad_pose);
      grad_hidden = grad_hidden + at::mm(grad_pose, weight_out);
      grad_hidden = gru_step_backward(grad_hidden, hiddens[t], state.step(t), weight_hh, grad_input_gates[t],
                                      grad_hidden_gates[t]);
      // Step t's input pose is y_{t-1}; its gradient flows on to step t-1.
      grad_from_future = at::mm(grad_input_gates[t], weight_ih.narrow(1, 0, dims));
      if (residual) grad_from_future = grad_from_future + grad_pose;
    }
    at::Tensor grad_code;
    if (feed_code) {
      grad_code = at::mm(grad_input_gates.sum(0), weight_ih.narrow(1, dims, weight_ih.size(1) - dims));
    }
    auto [grad_weight_ih, grad_bias_ih] = weight_and_bias_grad(grad_input_gates, state.inputs);
    auto [grad_weight_hh, grad_bias_hh] = weight_and_bias_grad(grad_hidden_gates, state.previous_hiddens());
    auto [grad_weight_out, grad_bias_out] = weight_and_bias_grad(grad_outputs_total, hiddens.narrow(0, 1, frames));
    return {grad_hidden,    grad_code,       grad_weight_ih,  grad_bias_ih, grad_weight_hh,
            grad_bias_hh,   grad_weight_out, grad_bias_out,   at::Tensor(), at::Tensor(),
            at::Tensor()};
  }
};

}  // namespace

at::Tensor gru_last_hidden(const at::Tensor& inputs, const at::Tensor& h0, const GruWeights& gru) {
  return LastHidden::apply(inputs, h0, gru.weight_ih, gru.bias_ih, gru.weight_hh, gru.bias_hh);
}

at::Tensor gru_autoregressive(const at::Tensor& h0, const at::Tensor& code, const GruWeights& gru,
                              const at::Tensor& weight_out, const at::Tensor& bias_out, int64_t frames, bool residual,
                              bool feed_code) {
  return Autoregressive::apply(h0, code, gru.weight_ih, gru.bias_ih, gru.weight_hh, gru.bias_hh, weight_out, bias_out,
                               frames, residual, feed_code);
}

}  // namespace mm
