#include "gru_recurrence.h"

#include <torch/csrc/autograd/custom_function.h>

namespace mm {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// One GRU step in the layout of LibTorch's fused GRU cell: the gates
// (B, 3H) already hold their biases, and the step's workspace (B, 5H) keeps
// r, z, n, the previous hidden state h and the (W_hn h + b_hn) term, which is
// all its backward pass needs. On CUDA the fused cell does a step in one
// kernel; a training step is launch-bound there (hundreds of dependent
// steps), so the number of kernels per step is what sets its time.
struct CellStep {
  at::Tensor hidden;     // h' = (1 - z) n + z h
  at::Tensor workspace;  // (B, 5H): r, z, n, h, hn
};

CellStep cell_forward(const at::Tensor& input_gates, const at::Tensor& hidden_gates, const at::Tensor& hidden) {
  if (hidden.is_cuda()) {
    auto [next, workspace] = at::_thnn_fused_gru_cell(input_gates, hidden_gates, hidden);
    return {next, workspace};
  }
  const int64_t h = hidden.size(1);
  auto workspace = at::empty({hidden.size(0), 5 * h}, hidden.options());
  auto reset = workspace.narrow(1, 0, h), update = workspace.narrow(1, h, h);
  auto candidate = workspace.narrow(1, 2 * h, h), hidden_n = workspace.narrow(1, 4 * h, h);
  auto reset_and_update = workspace.narrow(1, 0, 2 * h);
  at::sigmoid_out(reset_and_update, input_gates.narrow(1, 0, 2 * h) + hidden_gates.narrow(1, 0, 2 * h));
  hidden_n.copy_(hidden_gates.narrow(1, 2 * h, h));
  workspace.narrow(1, 3 * h, h).copy_(hidden);
  at::tanh_out(candidate, at::addcmul(input_gates.narrow(1, 2 * h, h), reset, hidden_n));
  return {candidate + update * (hidden - candidate), workspace};
}

// The gradients of one step given dL/dh': of the input and hidden gate
// pre-activations, and of h along the direct path only (z * dL/dh'; the
// path through the gates is grad_hidden_gates . W_hh, added by the caller).
struct CellGrad {
  at::Tensor input_gates, hidden_gates, hidden_direct;
};

CellGrad cell_backward(const at::Tensor& grad_next, const at::Tensor& workspace) {
  if (grad_next.is_cuda()) {
    auto grads = at::_thnn_fused_gru_cell_backward(grad_next, workspace, /*has_bias=*/false);
    return {std::get<0>(grads), std::get<1>(grads), std::get<2>(grads)};
  }
  const int64_t h = workspace.size(1) / 5;
  auto reset = workspace.narrow(1, 0, h), update = workspace.narrow(1, h, h);
  auto candidate = workspace.narrow(1, 2 * h, h), hidden = workspace.narrow(1, 3 * h, h);
  auto hidden_n = workspace.narrow(1, 4 * h, h);
  auto grad_candidate = grad_next * (1 - update) * (1 - candidate * candidate);
  auto grad_update = grad_next * (hidden - candidate) * update * (1 - update);
  auto grad_reset = grad_candidate * hidden_n * reset * (1 - reset);
  return {at::cat({grad_reset, grad_update, grad_candidate}, 1),
          at::cat({grad_reset, grad_update, grad_candidate * reset}, 1), grad_next * update};
}

// h_0 .. h_{T-1}, what each step's hidden gates were computed from, out of
// the stacked workspaces (T, B, 5H).
at::Tensor previous_hiddens(const at::Tensor& workspaces) {
  const int64_t h = workspaces.size(2) / 5;
  return workspaces.narrow(2, 3 * h, h);
}

// The weight gradient sum_t grad_gates[t]^T . inputs[t] as one product, and
// the bias gradient, over the first two dimensions.
std::pair<at::Tensor, at::Tensor> weight_and_bias_grad(const at::Tensor& grad_gates, const at::Tensor& inputs) {
  auto g = grad_gates.reshape({-1, grad_gates.size(-1)});
  return {at::mm(g.t(), inputs.reshape({-1, inputs.size(-1)})), g.sum(0)};
}

struct LastHidden : public torch::autograd::Function<LastHidden> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& inputs, const at::Tensor& h0,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh) {
    const int64_t batch = inputs.size(0), frames = inputs.size(1);
    auto time_major = inputs.transpose(0, 1).contiguous();  // (T, B, I)
    auto input_gates = at::addmm(bias_ih, time_major.view({frames * batch, -1}), weight_ih.t()).view({frames, batch, -1});
    const auto weight_hh_t = weight_hh.t();
    std::vector<at::Tensor> workspaces(frames);
    at::Tensor hidden = h0;
    for (int64_t t = 0; t < frames; ++t) {
      auto step = cell_forward(input_gates[t], at::addmm(bias_hh, hidden, weight_hh_t), hidden);
      hidden = step.hidden;
      workspaces[t] = step.workspace;
    }
    ctx->save_for_backward({weight_ih, weight_hh});
    ctx->saved_data["inputs"] = time_major;
    ctx->saved_data["workspaces"] = at::stack(workspaces);
    return hidden;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto &weight_ih = saved[0], &weight_hh = saved[1];
    const auto inputs = ctx->saved_data["inputs"].toTensor();
    const auto workspaces = ctx->saved_data["workspaces"].toTensor();
    const int64_t frames = inputs.size(0), batch = inputs.size(1), size = weight_hh.size(1);
    std::vector<at::Tensor> grad_input_gates(frames), grad_hidden_gates(frames);
    auto grad_hidden =
        grad_outputs[0].defined() ? grad_outputs[0] : at::zeros({batch, size}, workspaces.options());
    for (int64_t t = frames - 1; t >= 0; --t) {
      auto grad = cell_backward(grad_hidden, workspaces[t]);
      grad_input_gates[t] = grad.input_gates;
      grad_hidden_gates[t] = grad.hidden_gates;
      grad_hidden = at::addmm(grad.hidden_direct, grad.hidden_gates, weight_hh);
    }
    auto input_gates = at::stack(grad_input_gates), hidden_gates = at::stack(grad_hidden_gates);
    auto grad_inputs = at::matmul(input_gates, weight_ih).transpose(0, 1);
    auto [grad_weight_ih, grad_bias_ih] = weight_and_bias_grad(input_gates, inputs);
    auto [grad_weight_hh, grad_bias_hh] = weight_and_bias_grad(hidden_gates, previous_hiddens(workspaces));
    return {grad_inputs, grad_hidden, grad_weight_ih, grad_bias_ih, grad_weight_hh, grad_bias_hh};
  }
};

struct Autoregressive : public torch::autograd::Function<Autoregressive> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& h0, const at::Tensor& code,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh, const at::Tensor& weight_out, const at::Tensor& bias_out,
                            int64_t frames, bool residual, bool feed_code) {
    const int64_t batch = h0.size(0), dims = weight_out.size(0);
    // Step t's input is (y_{t-1}, code): the code's share of the input gates
    // is the same at every step, and y_{-1} is zero.
    const auto steady_gates =
        feed_code ? at::addmm(bias_ih, code, weight_ih.narrow(1, dims, weight_ih.size(1) - dims).t())
                  : bias_ih.expand({batch, bias_ih.size(0)}).contiguous();
    const auto weight_pose_t = weight_ih.narrow(1, 0, dims).t(), weight_hh_t = weight_hh.t();
    const auto weight_out_t = weight_out.t();
    std::vector<at::Tensor> workspaces(frames), hiddens(frames), poses(frames);
    at::Tensor hidden = h0, pose;
    for (int64_t t = 0; t < frames; ++t) {
      auto input_gates = t == 0 ? steady_gates : at::addmm(steady_gates, pose, weight_pose_t);
      auto step = cell_forward(input_gates, at::addmm(bias_hh, hidden, weight_hh_t), hidden);
      hidden = step.hidden;
      auto next = at::addmm(bias_out, hidden, weight_out_t);
      if (residual && t > 0) next.add_(pose);
      pose = next;
      workspaces[t] = step.workspace;
      hiddens[t] = hidden;
      poses[t] = pose;
    }
    auto outputs = at::stack(poses);
    ctx->save_for_backward({weight_ih, weight_hh, weight_out});
    ctx->saved_data["workspaces"] = at::stack(workspaces);
    ctx->saved_data["hiddens"] = at::stack(hiddens);  // h_1 .. h_T, what the poses were computed from
    ctx->saved_data["poses"] = outputs.clone();       // the inputs of steps 1 .. T, kept apart from the output
    ctx->saved_data["code"] = feed_code ? code : at::Tensor();
    ctx->saved_data["residual"] = residual;
    return outputs;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto &weight_ih = saved[0], &weight_hh = saved[1], &weight_out = saved[2];
    const auto workspaces = ctx->saved_data["workspaces"].toTensor();
    const auto hiddens = ctx->saved_data["hiddens"].toTensor(), poses = ctx->saved_data["poses"].toTensor();
    const auto code = ctx->saved_data["code"].toTensor();
    const bool residual = ctx->saved_data["residual"].toBool(), feed_code = code.defined();
    const int64_t frames = poses.size(0), batch = poses.size(1), dims = poses.size(2), size = weight_hh.size(1);
    auto opts = poses.options();
    auto grad_poses = grad_outputs[0].defined() ? grad_outputs[0] : at::zeros({frames, batch, dims}, opts);
    const auto weight_pose = weight_ih.narrow(1, 0, dims);
    std::vector<at::Tensor> grad_input_gates(frames), grad_hidden_gates(frames), grad_pose_total(frames);
    auto grad_hidden = at::zeros({batch, size}, opts);
    at::Tensor grad_from_later;  // into y_t from step t+1's input and residual
    for (int64_t t = frames - 1; t >= 0; --t) {
      auto grad_pose = grad_from_later.defined() ? grad_poses[t] + grad_from_later : grad_poses[t];
      grad_pose_total[t] = grad_pose;
      auto grad = cell_backward(at::addmm(grad_hidden, grad_pose, weight_out), workspaces[t]);
      grad_input_gates[t] = grad.input_gates;
      grad_hidden_gates[t] = grad.hidden_gates;
      grad_hidden = at::addmm(grad.hidden_direct, grad.hidden_gates, weight_hh);
      if (t > 0) {  // step t's input pose is y_{t-1}, and with the residual so is y_t itself
        grad_from_later = residual ? at::addmm(grad_pose, grad.input_gates, weight_pose)
                                   : at::mm(grad.input_gates, weight_pose);
      }
    }
    auto input_gates = at::stack(grad_input_gates), hidden_gates = at::stack(grad_hidden_gates);
    auto pose_grads = at::stack(grad_pose_total);
    // dW_ih = sum_t dG_t^T (y_{t-1}, code) with y_{-1} = 0.
    auto grad_weight_ih = at::zeros_like(weight_ih);
    if (frames > 1) {
      grad_weight_ih.narrow(1, 0, dims).copy_(
          weight_and_bias_grad(input_gates.narrow(0, 1, frames - 1), poses.narrow(0, 0, frames - 1)).first);
    }
    auto input_gate_sum = input_gates.sum(0);  // (B, 3H)
    at::Tensor grad_code;
    if (feed_code) {
      const int64_t latent = weight_ih.size(1) - dims;
      grad_weight_ih.narrow(1, dims, latent).copy_(at::mm(input_gate_sum.t(), code));
      grad_code = at::mm(input_gate_sum, weight_ih.narrow(1, dims, latent));
    }
    auto grad_bias_ih = input_gate_sum.sum(0);
    auto [grad_weight_hh, grad_bias_hh] = weight_and_bias_grad(hidden_gates, previous_hiddens(workspaces));
    auto [grad_weight_out, grad_bias_out] = weight_and_bias_grad(pose_grads, hiddens);
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
