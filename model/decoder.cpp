#include "model/decoder.h"

#include <c10/core/InferenceMode.h>

#include "format/input_error.h"
#include "model/gru_inference.h"
#include "model/gru_recurrence.h"
#include "model/packed_linear.h"

namespace mm {

struct DecoderImpl::Packed {
  PackedLinear from_code, input, hidden, to_pose;
  bool current() const { return from_code.current() && input.current() && hidden.current() && to_pose.current(); }
};

void DecoderImpl::pack_for_inference(Precision precision) {
  const Precision outside = outside_recurrence(precision);
  packed_.reset(new Packed{PackedLinear(from_code_->weight, from_code_->bias, outside),
                           PackedLinear(cell_->weight_ih, cell_->bias_ih, outside),
                           PackedLinear(cell_->weight_hh, cell_->bias_hh, precision),
                           PackedLinear(to_pose_->weight, to_pose_->bias, outside)});
}

DecoderImpl::DecoderImpl(const DecoderShape& shape)
    : shape_(shape),
      from_code_(register_module("from_code", torch::nn::Linear(shape.latent, shape.hidden))),
      cell_(register_module("cell", torch::nn::GRUCell(shape.pose_dims + (shape.feed_code ? shape.latent : 0),
                                                        shape.hidden))),
      to_pose_(register_module("to_pose", torch::nn::Linear(shape.hidden, shape.pose_dims))) {}

at::Tensor DecoderImpl::forward(const at::Tensor& z) { return forward_together({this}, z)[0]; }

std::vector<at::Tensor> forward_together(const std::vector<DecoderImpl*>& decoders, const at::Tensor& z) {
  if (decoders.empty()) throw InputError("decoders", "expected at least one decoder");
  const DecoderShape& shape = decoders[0]->shape();
  for (const auto* d : decoders) {
    const DecoderShape& s = d->shape();
    if (s.pose_dims != shape.pose_dims || s.hidden != shape.hidden || s.latent != shape.latent ||
        s.frames != shape.frames || s.feed_code != shape.feed_code) {
      throw InputError("decoders", "expected decoders of one shape to run together");
    }
  }
  // One weight set per decoder along a new first dimension (a view for one).
  auto stacked = [&](auto member) {
    std::vector<at::Tensor> parts;
    for (auto* d : decoders) parts.push_back(member(*d));
    return parts.size() == 1 ? parts[0].unsqueeze(0) : at::stack(parts);
  };
  const int64_t count = static_cast<int64_t>(decoders.size());
  std::vector<bool> residual;
  for (const auto* d : decoders) residual.push_back(d->shape().residual);
  const AutoregressiveWeights weights{
      GruWeights{stacked([](DecoderImpl& d) { return d.cell_->weight_ih; }),
                 stacked([](DecoderImpl& d) { return d.cell_->bias_ih; }),
                 stacked([](DecoderImpl& d) { return d.cell_->weight_hh; }),
                 stacked([](DecoderImpl& d) { return d.cell_->bias_hh; })},
      stacked([](DecoderImpl& d) { return d.to_pose_->weight; }),
      stacked([](DecoderImpl& d) { return d.to_pose_->bias; }), residual};
  auto h0 = at::baddbmm(stacked([](DecoderImpl& d) { return d.from_code_->bias; }).unsqueeze(1),
                        z.expand({count, z.size(0), z.size(1)}),
                        stacked([](DecoderImpl& d) { return d.from_code_->weight; }).transpose(1, 2));
  auto generated = gru_autoregressive(h0, z, weights, shape.frames, shape.feed_code);  // Eq. 2-3 / 5-6, (K, T, B, D)
  std::vector<at::Tensor> poses;
  for (int64_t k = 0; k < count; ++k) poses.push_back(generated[k].flip(0).transpose(0, 1));  // last frame first
  return poses;
}

at::Tensor DecoderImpl::forward_stepwise(const at::Tensor& z) {
  const int64_t batch = z.size(0);
  auto hidden = from_code_->forward(z);
  auto previous = at::zeros({batch, shape_.pose_dims}, z.options());  // no frame after the last one
  std::vector<at::Tensor> generated;
  generated.reserve(shape_.frames);
  for (int step = 0; step < shape_.frames; ++step) {
    auto input = shape_.feed_code ? at::cat({previous, z}, 1) : previous;
    hidden = cell_->forward(input, hidden);                       // Eq. 2 / 5
    auto pose = to_pose_->forward(hidden);                        // Eq. 3
    if (shape_.residual) pose = pose + previous;                  // Eq. 6
    generated.push_back(pose);
    previous = pose;
  }
  return at::stack(generated, 1).flip(1);  // generated last frame first
}

at::Tensor DecoderImpl::generate(const at::Tensor& z) const {
  c10::InferenceMode inference;
  if (!z.device().is_cpu() || z.scalar_type() != at::kFloat) {
    return const_cast<DecoderImpl*>(this)->forward_stepwise(z);
  }
  const int64_t batch = z.size(0), hidden_size = shape_.hidden, dims = shape_.pose_dims;
  const auto& cell = *cell_;
  auto code = z.contiguous();
  const auto packed = packed_ && packed_->current() ? packed_ : nullptr;
  auto hidden = at::empty({batch, hidden_size});
  if (packed) {
    packed->from_code.apply(code, hidden);
  } else {
    affine_into(hidden, from_code_->bias, from_code_->weight, code);
  }

  const int64_t input_size = dims + (shape_.feed_code ? shape_.latent : 0);
  auto input = at::zeros({batch, input_size});
  if (shape_.feed_code) input.narrow(1, dims, shape_.latent).copy_(code);
  auto input_gates = at::empty({batch, 3 * hidden_size});
  auto hidden_gates = at::empty({batch, 3 * hidden_size});
  auto pose = at::empty({batch, dims});
  auto generated = at::empty({shape_.frames, batch, dims});

  for (int step = 0; step < shape_.frames; ++step) {
    if (packed) {
      packed->input.apply(input, input_gates);
      packed->hidden.apply(hidden, hidden_gates);
      gru_combine(hidden, input_gates, hidden_gates);
      packed->to_pose.apply(hidden, pose);
    } else {
      affine_into(input_gates, cell.bias_ih, cell.weight_ih, input);
      gru_update(hidden, input_gates, hidden_gates, cell.weight_hh, cell.bias_hh);
      affine_into(pose, to_pose_->bias, to_pose_->weight, hidden);
    }
    // The pose becomes the next step's input (after the residual) and the
    // clip's frame: plain loops, a few hundred values each, where LibTorch
    // calls cost more than the copies at batch 1.
    float* pose_rows = pose.data_ptr<float>();
    float* input_rows = input.data_ptr<float>();
    float* frame_rows = generated.data_ptr<float>() + step * batch * dims;
    for (int64_t b = 0; b < batch; ++b) {
      float* p = pose_rows + b * dims;
      float* previous = input_rows + b * input_size;
      for (int64_t d = 0; d < dims; ++d) {
        if (shape_.residual) p[d] += previous[d];
        previous[d] = p[d];
        frame_rows[b * dims + d] = p[d];
      }
    }
  }
  return generated.flip(0).transpose(0, 1).contiguous();
}

}  // namespace mm
