#include "model/gru_recurrence.h"

#include <torch/csrc/autograd/custom_function.h>

#include <algorithm>
#include <string>
#include <vector>

#include "model/cuda_graph_replay.h"

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
// the stacked workspaces (T, B, 5H) or (K, T, B, 5H).
at::Tensor previous_hiddens(const at::Tensor& workspaces) {
  const int64_t h = workspaces.size(-1) / 5;
  return workspaces.narrow(-1, 3 * h, h);
}

// The weight gradient sum_t grad_gates[t]^T . inputs[t] as one product, and
// the bias gradient, over the time and batch dimensions: of (T, B, .)
// tensors, or per decoder of (K, T, B, .) tensors.
std::pair<at::Tensor, at::Tensor> weight_and_bias_grad(const at::Tensor& grad_gates, const at::Tensor& inputs) {
  if (grad_gates.dim() == 4) {
    const int64_t decoders = grad_gates.size(0);
    auto g = grad_gates.reshape({decoders, -1, grad_gates.size(-1)});
    return {at::bmm(g.transpose(1, 2), inputs.reshape({decoders, -1, inputs.size(-1)})), g.sum(1)};
  }
  auto g = grad_gates.reshape({-1, grad_gates.size(-1)});
  return {at::mm(g.t(), inputs.reshape({-1, inputs.size(-1)})), g.sum(0)};
}

// The encoder's recurrence, forward: from (inputs, h0, weight_ih, bias_ih,
// weight_hh, bias_hh) to (last hidden state, time-major inputs, the steps'
// workspaces), what the backward pass needs.
std::vector<at::Tensor> last_hidden_forward(const std::vector<at::Tensor>& in) {
  const auto &inputs = in[0], &h0 = in[1], &weight_ih = in[2], &bias_ih = in[3], &weight_hh = in[4],
             &bias_hh = in[5];
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
  return {hidden, time_major, at::stack(workspaces)};
}

// Backward: from (dL/dh_T, time-major inputs, workspaces, weight_ih,
// weight_hh) to the gradients of forward's six inputs.
std::vector<at::Tensor> last_hidden_backward(const std::vector<at::Tensor>& in) {
  const auto &grad_last = in[0], &inputs = in[1], &workspaces = in[2], &weight_ih = in[3], &weight_hh = in[4];
  const int64_t frames = inputs.size(0);
  std::vector<at::Tensor> grad_input_gates(frames), grad_hidden_gates(frames);
  auto grad_hidden = grad_last;
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

// Each direction of a recurrence runs as one CUDA graph on a GPU
// (cuda_graph_replay.h): hundreds of dependent steps launched at once.
struct LastHidden : public torch::autograd::Function<LastHidden> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& inputs, const at::Tensor& h0,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh) {
    auto out = run_as_cuda_graph("gru_last_hidden forward", {inputs, h0, weight_ih, bias_ih, weight_hh, bias_hh},
                                 last_hidden_forward);
    ctx->save_for_backward({weight_ih, weight_hh});
    ctx->saved_data["inputs"] = out[1];
    ctx->saved_data["workspaces"] = out[2];
    return out[0];
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto workspaces = ctx->saved_data["workspaces"].toTensor();
    const auto& weight_hh = saved[1];
    auto grad_last = grad_outputs[0].defined()
                         ? grad_outputs[0]
                         : at::zeros({workspaces.size(1), weight_hh.size(1)}, workspaces.options());
    return run_as_cuda_graph("gru_last_hidden backward",
                             {grad_last, ctx->saved_data["inputs"].toTensor(), workspaces, saved[0], weight_hh},
                             last_hidden_backward);
  }
};

// bias + x . weight per decoder: (K, B, O) from x (K, B, I) and weight
// (K, I, O); bias broadcasts to (K, B, O), or is undefined for none. One
// decoder takes the plain matrix product: on the CPU the batched one is
// slower for a single matrix (a training step at batch 4 took 9% longer).
at::Tensor affine(const at::Tensor& bias, const at::Tensor& x, const at::Tensor& weight) {
  if (x.size(0) == 1) {
    if (!bias.defined()) return at::mm(x[0], weight[0]).unsqueeze(0);
    auto row = bias[0];
    if (row.dim() == 2 && row.size(0) == 1) row = row.squeeze(0);  // a bias vector, as the plain product takes it
    return at::addmm(row, x[0], weight[0]).unsqueeze(0);
  }
  return bias.defined() ? at::baddbmm(bias, x, weight) : at::bmm(x, weight);
}

// Which decoders add their previous output, as the step needs it: nothing
// to do when none does, a plain addition when all do, and a (K, 1, 1) scale
// of zeros and ones made on the device (no host-to-device copy, which would
// make the host wait for the GPU) when they differ.
struct ResidualPlan {
  bool any = false;
  at::Tensor scale;  // defined only for a mix

  ResidualPlan(const std::vector<bool>& residual, const at::TensorOptions& options) {
    const bool all = std::all_of(residual.begin(), residual.end(), [](bool r) { return r; });
    any = std::any_of(residual.begin(), residual.end(), [](bool r) { return r; });
    if (any && !all) {
      std::vector<at::Tensor> flags;
      for (bool r : residual) flags.push_back(at::full({1, 1}, r ? 1.0 : 0.0, options));
      scale = at::stack(flags);
    }
  }
  // previous + next where residual, in place on next.
  void add_previous(at::Tensor& next, const at::Tensor& previous) const {
    if (scale.defined()) {
      next.addcmul_(scale, previous);
    } else if (any) {
      next.add_(previous);
    }
  }
  // The share of dL/dy_t that flows into y_{t-1} through the addition.
  at::Tensor previous_share(const at::Tensor& grad) const {
    if (!any) return at::Tensor();
    return scale.defined() ? grad * scale : grad;
  }
};

// K decoders of one shape run as one recurrence: every per-step product is
// a batched product over the K weight sets, so a step costs the same number
// of kernels for both decoders of a model as for one. Tensors are (K, B, .)
// with each decoder's rows contiguous, so (K * B, .) views feed the cell.
struct AutoregressiveShape {
  int64_t frames;
  bool feed_code;
  std::vector<bool> residual;

  // What fixes the captured work beside the input shapes.
  std::string name(const char* direction) const {
    std::string flags;
    for (bool r : residual) flags += r ? '1' : '0';
    return std::string("gru_autoregressive ") + direction + " frames " + std::to_string(frames) + " code " +
           (feed_code ? "1" : "0") + " residual " + flags;
  }
};

// Forward: from (h0, code or undefined, weight_ih, bias_ih, weight_hh,
// bias_hh, weight_out, bias_out) to (outputs (K, T, B, D), workspaces
// (T, K, B, 5H), hiddens h_1 .. h_T (K, T, B, H)).
std::vector<at::Tensor> autoregressive_forward(const std::vector<at::Tensor>& in, const AutoregressiveShape& shape) {
  const auto &h0 = in[0], &code = in[1], &weight_ih = in[2], &bias_ih = in[3], &weight_hh = in[4], &bias_hh = in[5],
             &weight_out = in[6], &bias_out = in[7];
  const int64_t decoders = h0.size(0), batch = h0.size(1), size = h0.size(2), dims = weight_out.size(1);
  // Step t's input is (y_{t-1}, code): the code's share of the input gates
  // is the same at every step, and y_{-1} is zero.
  const auto bias_ih_rows = bias_ih.unsqueeze(1);
  const auto steady_gates = shape.feed_code
                                ? affine(bias_ih_rows, code.expand({decoders, batch, code.size(1)}),
                                         weight_ih.narrow(2, dims, weight_ih.size(2) - dims).transpose(1, 2))
                                : bias_ih_rows.expand({decoders, batch, bias_ih.size(1)}).contiguous();
  const auto weight_pose_t = weight_ih.narrow(2, 0, dims).transpose(1, 2), weight_hh_t = weight_hh.transpose(1, 2);
  const auto weight_out_t = weight_out.transpose(1, 2), bias_hh_rows = bias_hh.unsqueeze(1);
  const auto bias_out_rows = bias_out.unsqueeze(1);
  const ResidualPlan plan(shape.residual, h0.options());
  std::vector<at::Tensor> workspaces(shape.frames), hiddens(shape.frames), poses(shape.frames);
  at::Tensor hidden = h0.contiguous(), pose;
  for (int64_t t = 0; t < shape.frames; ++t) {
    auto input_gates = t == 0 ? steady_gates : affine(steady_gates, pose, weight_pose_t);
    auto hidden_gates = affine(bias_hh_rows, hidden, weight_hh_t);
    auto step = cell_forward(input_gates.view({decoders * batch, -1}), hidden_gates.view({decoders * batch, -1}),
                             hidden.view({decoders * batch, size}));
    hidden = step.hidden.view({decoders, batch, size});
    auto next = affine(bias_out_rows, hidden, weight_out_t);
    if (t > 0) plan.add_previous(next, pose);  // the velocity decoder adds its previous output
    pose = next;
    workspaces[t] = step.workspace.view({decoders, batch, -1});
    hiddens[t] = hidden;
    poses[t] = pose;
  }
  return {at::stack(poses, 1), at::stack(workspaces), at::stack(hiddens, 1)};
}

// Backward: from (dL/d outputs, workspaces, hiddens, poses, code or
// undefined, weight_ih, weight_hh, weight_out) to the gradients of the
// forward's eight inputs (that of the code undefined without one).
std::vector<at::Tensor> autoregressive_backward(const std::vector<at::Tensor>& in, const AutoregressiveShape& shape) {
  const auto &grad_poses = in[0], &workspaces = in[1], &hiddens = in[2], &poses = in[3], &code = in[4],
             &weight_ih = in[5], &weight_hh = in[6], &weight_out = in[7];
  const int64_t decoders = poses.size(0), frames = poses.size(1), batch = poses.size(2), dims = poses.size(3);
  const int64_t size = weight_hh.size(2);
  auto opts = poses.options();
  const auto weight_pose = weight_ih.narrow(2, 0, dims);
  const ResidualPlan plan(shape.residual, opts);
  std::vector<at::Tensor> grad_input_gates(frames), grad_hidden_gates(frames), grad_pose_total(frames);
  auto grad_hidden = at::zeros({decoders, batch, size}, opts);
  at::Tensor grad_from_later;  // into y_t from step t+1's input and residual
  for (int64_t t = frames - 1; t >= 0; --t) {
    auto grad_pose = grad_poses.select(1, t);
    if (grad_from_later.defined()) grad_pose = grad_pose + grad_from_later;
    grad_pose_total[t] = grad_pose;
    auto grad_next = affine(grad_hidden, grad_pose, weight_out);
    auto grad = cell_backward(grad_next.view({decoders * batch, size}), workspaces[t].view({decoders * batch, -1}));
    auto input_gates = grad.input_gates.view({decoders, batch, -1});
    auto hidden_gates = grad.hidden_gates.view({decoders, batch, -1});
    grad_input_gates[t] = input_gates;
    grad_hidden_gates[t] = hidden_gates;
    grad_hidden = affine(grad.hidden_direct.view({decoders, batch, size}), hidden_gates, weight_hh);
    if (t > 0) {  // step t's input pose is y_{t-1}, and with the residual so is y_t itself
      grad_from_later = affine(plan.previous_share(grad_pose), input_gates, weight_pose);
    }
  }
  auto input_gates = at::stack(grad_input_gates, 1), hidden_gates = at::stack(grad_hidden_gates, 1);  // (K, T, B, 3H)
  auto pose_grads = at::stack(grad_pose_total, 1);
  // dW_ih = sum_t dG_t^T (y_{t-1}, code) with y_{-1} = 0.
  auto grad_weight_ih = at::zeros_like(weight_ih);
  if (frames > 1) {
    grad_weight_ih.narrow(2, 0, dims).copy_(
        weight_and_bias_grad(input_gates.narrow(1, 1, frames - 1), poses.narrow(1, 0, frames - 1)).first);
  }
  auto input_gate_sum = input_gates.sum(1);  // (K, B, 3H)
  at::Tensor grad_code;
  if (shape.feed_code) {
    const int64_t latent = weight_ih.size(2) - dims;
    const auto weight_code = weight_ih.narrow(2, dims, latent);
    grad_weight_ih.narrow(2, dims, latent).copy_(at::matmul(input_gate_sum.transpose(1, 2), code));
    grad_code = at::bmm(input_gate_sum, weight_code).sum(0);
  }
  auto grad_bias_ih = input_gate_sum.sum(1);
  auto [grad_weight_hh, grad_bias_hh] = weight_and_bias_grad(hidden_gates, previous_hiddens(workspaces).transpose(0, 1));
  auto [grad_weight_out, grad_bias_out] = weight_and_bias_grad(pose_grads, hiddens);
  return {grad_hidden,    grad_code,      grad_weight_ih,  grad_bias_ih,
          grad_weight_hh, grad_bias_hh,   grad_weight_out, grad_bias_out};
}

struct Autoregressive : public torch::autograd::Function<Autoregressive> {
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& h0, const at::Tensor& code,
                            const at::Tensor& weight_ih, const at::Tensor& bias_ih, const at::Tensor& weight_hh,
                            const at::Tensor& bias_hh, const at::Tensor& weight_out, const at::Tensor& bias_out,
                            int64_t frames, bool feed_code, std::vector<bool> residual) {
    const AutoregressiveShape shape{frames, feed_code, residual};
    auto out = run_as_cuda_graph(
        shape.name("forward"),
        {h0, feed_code ? code : at::Tensor(), weight_ih, bias_ih, weight_hh, bias_hh, weight_out, bias_out},
        [&shape](const std::vector<at::Tensor>& in) { return autoregressive_forward(in, shape); });
    ctx->save_for_backward({weight_ih, weight_hh, weight_out});
    ctx->saved_data["frames"] = frames;
    ctx->saved_data["residual"] = std::vector<int64_t>(residual.begin(), residual.end());
    ctx->saved_data["workspaces"] = out[1];  // each step's contiguous
    ctx->saved_data["hiddens"] = out[2];     // h_1 .. h_T, what the poses were computed from
    ctx->saved_data["poses"] = out[0].clone();  // the inputs of steps 1 .. T, kept apart from the output
    ctx->saved_data["code"] = feed_code ? code : at::Tensor();
    return out[0];
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    auto saved = ctx->get_saved_variables();
    const auto flags = ctx->saved_data["residual"].toIntVector();
    const auto code = ctx->saved_data["code"].toTensor();
    const auto poses = ctx->saved_data["poses"].toTensor();
    const AutoregressiveShape shape{ctx->saved_data["frames"].toInt(), code.defined(),
                                    std::vector<bool>(flags.begin(), flags.end())};
    auto grads = run_as_cuda_graph(
        shape.name("backward"),
        {grad_outputs[0].defined() ? grad_outputs[0] : at::zeros_like(poses), ctx->saved_data["workspaces"].toTensor(),
         ctx->saved_data["hiddens"].toTensor(), poses, code, saved[0], saved[1], saved[2]},
        [&shape](const std::vector<at::Tensor>& in) { return autoregressive_backward(in, shape); });
    grads.insert(grads.end(), {at::Tensor(), at::Tensor(), at::Tensor()});  // frames, feed_code, residual
    return grads;
  }
};

}  // namespace

at::Tensor gru_last_hidden(const at::Tensor& inputs, const at::Tensor& h0, const GruWeights& gru) {
  return LastHidden::apply(inputs, h0, gru.weight_ih, gru.bias_ih, gru.weight_hh, gru.bias_hh);
}

at::Tensor gru_autoregressive(const at::Tensor& h0, const at::Tensor& code, const AutoregressiveWeights& w,
                              int64_t frames, bool feed_code) {
  return Autoregressive::apply(h0, code, w.gru.weight_ih, w.gru.bias_ih, w.gru.weight_hh, w.gru.bias_hh, w.weight_out,
                               w.bias_out, frames, feed_code, w.residual);
}

}  // namespace mm
