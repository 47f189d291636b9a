#include <c10/core/InferenceMode.h>
#include <gtest/gtest.h>
#include <torch/cuda.h>

#include "format/input_error.h"
#include "model/decoder.h"
#include "model/discriminator.h"
#include "model/encoder.h"

namespace mm {
namespace {

TEST(Networks, ShapesFollowTheConfiguration) {
  Encoder encoder(51, 32, 8);
  Decoder decoder(DecoderShape{51, 32, 8, 40, false, false});
  Discriminator discriminator(51);
  auto motion = at::randn({3, 40, 51});
  auto z = encoder->forward(motion);
  EXPECT_EQ(z.sizes(), (std::vector<int64_t>{3, 8}));
  EXPECT_EQ(decoder->forward(z).sizes(), (std::vector<int64_t>{3, 40, 51}));
  EXPECT_EQ(discriminator->forward(motion).sizes(), (std::vector<int64_t>{3}));
}

void copy_parameters(torch::nn::Module& from, torch::nn::Module& to) {
  c10::InferenceMode guard(false);
  at::NoGradGuard no_grad;
  auto source = from.named_parameters();
  for (auto& p : to.named_parameters()) p.value().copy_(source[p.key()]);
}

TEST(Networks, DecoderGeneratesTheLastFrameFirst) {
  // A one-frame decoder with the same weights produces only the first
  // generated pose; it must come out as the last frame of the long clip.
  at::manual_seed(5);
  for (bool residual : {false, true}) {
    Decoder long_clip(DecoderShape{51, 16, 4, 10, residual, false});
    Decoder one_frame(DecoderShape{51, 16, 4, 1, residual, false});
    copy_parameters(*long_clip, *one_frame);
    auto z = at::randn({2, 4});
    auto full = long_clip->forward(z);
    EXPECT_TRUE(at::allclose(full.select(1, 9), one_frame->forward(z).select(1, 0), 1e-6, 1e-6));
    EXPECT_FALSE(at::allclose(full.select(1, 0), one_frame->forward(z).select(1, 0), 1e-3, 1e-3));
  }
}

TEST(Networks, FastDecoderPathMatchesAutogradPath) {
  at::manual_seed(6);
  for (bool residual : {false, true}) {
    for (bool feed_code : {false, true}) {
      Decoder decoder(DecoderShape{51, 64, 8, 25, residual, feed_code});
      for (int64_t batch : {1, 3}) {
        auto z = at::randn({batch, 8});
        auto reference = decoder->forward_stepwise(z);
        auto fast = decoder->generate(z);
        EXPECT_TRUE(at::allclose(fast, reference, 1e-4, 1e-5))
            << "residual " << residual << " feed_code " << feed_code << " batch " << batch << " max diff "
            << (fast - reference).abs().max().item<float>();
      }
    }
  }
}

TEST(Networks, FastEncoderPathMatchesAutogradPath) {
  at::manual_seed(7);
  Encoder encoder(51, 64, 8);
  for (int64_t batch : {1, 4}) {
    auto motion = at::randn({batch, 30, 51});
    EXPECT_TRUE(at::allclose(encoder->encode(motion), encoder->forward_reference(motion), 1e-4, 1e-5));
  }
}

// Runs loss(module output) backward through both paths of a module and
// compares the outputs, the input gradient and every parameter gradient.
template <typename Module, typename Path>
void expect_same_values_and_gradients(Module& module, const at::Tensor& input, Path reference, const std::string& what) {
  auto weights = at::randn_like(reference(input));  // a random linear loss probes every output
  auto run = [&](bool fused) {
    module->zero_grad();
    auto x = input.detach().clone().requires_grad_(true);
    auto out = fused ? module->forward(x) : reference(x);
    (out * weights).sum().backward();
    std::vector<at::Tensor> grads{out.detach(), x.grad().clone()};
    for (auto& p : module->parameters()) grads.push_back(p.grad().clone());
    return grads;
  };
  auto fused = run(true), stepwise = run(false);
  ASSERT_EQ(fused.size(), stepwise.size());
  for (size_t i = 0; i < fused.size(); ++i) {
    const double scale = stepwise[i].abs().max().template item<double>() + 1e-6;
    const double diff = (fused[i] - stepwise[i]).abs().max().template item<double>();
    EXPECT_LT(diff / scale, 1e-4) << what << ": tensor " << i << " (0 = output, 1 = input gradient)";
  }
}

// The fused recurrences take another code path on CUDA (LibTorch's fused
// GRU cell), so both are checked against the stepwise autograd reference on
// every device this build can reach.
std::vector<at::Device> devices_to_check() {
  std::vector<at::Device> devices{at::kCPU};
  if (torch::cuda::is_available()) {
    devices.emplace_back(at::kCUDA, 0);
    at::globalContext().setAllowTF32CuDNN(false);  // the reference GRU runs in cuDNN: keep it in full float32
  }
  return devices;
}

TEST(Networks, FusedDecoderMatchesStepwiseAutogradInValuesAndGradients) {
  for (const auto& device : devices_to_check()) {
    at::manual_seed(9);
    for (bool residual : {false, true}) {
      for (bool feed_code : {false, true}) {
        Decoder decoder(DecoderShape{51, 32, 8, 20, residual, feed_code});
        decoder->to(device);
        expect_same_values_and_gradients(
            decoder, at::randn({3, 8}).to(device), [&](const at::Tensor& z) { return decoder->forward_stepwise(z); },
            device.str() + " residual " + std::to_string(residual) + " feed_code " + std::to_string(feed_code));
      }
    }
  }
}

// The training step runs the rotation and velocity decoders as one batched
// recurrence; each must still compute what it computes alone.
TEST(Networks, DecodersRunTogetherMatchEachStepwiseInValuesAndGradients) {
  for (const auto& device : devices_to_check()) {
    at::manual_seed(11);
    for (bool feed_code : {false, true}) {
      Decoder rotation(DecoderShape{51, 32, 8, 20, false, feed_code});
      Decoder velocity(DecoderShape{51, 32, 8, 20, true, feed_code});
      rotation->to(device);
      velocity->to(device);
      const auto z = at::randn({3, 8}).to(device);
      const auto weights = at::randn({2, 3, 20, 51}).to(device);
      auto run = [&](bool together) {
        rotation->zero_grad();
        velocity->zero_grad();
        auto code = z.clone().requires_grad_(true);
        auto outputs = together ? forward_together({rotation.get(), velocity.get()}, code)
                                : std::vector<at::Tensor>{rotation->forward_stepwise(code), velocity->forward_stepwise(code)};
        ((outputs[0] * weights[0]).sum() + (outputs[1] * weights[1]).sum()).backward();
        std::vector<at::Tensor> values{outputs[0].detach(), outputs[1].detach(), code.grad().clone()};
        for (auto* decoder : {rotation.get(), velocity.get()}) {
          for (auto& p : decoder->parameters()) values.push_back(p.grad().clone());
        }
        return values;
      };
      const auto together = run(true), stepwise = run(false);
      ASSERT_EQ(together.size(), stepwise.size());
      for (size_t i = 0; i < together.size(); ++i) {
        const double scale = stepwise[i].abs().max().item<double>() + 1e-6;
        EXPECT_LT((together[i] - stepwise[i]).abs().max().item<double>() / scale, 1e-4)
            << device.str() << " feed_code " << feed_code << ": tensor " << i
            << " (0, 1 = outputs, 2 = code gradient, then each decoder's parameter gradients)";
      }
    }
  }
}

TEST(Networks, DecodersOfDifferentShapesCannotRunTogether) {
  Decoder small(DecoderShape{51, 16, 8, 20, false, false});
  Decoder large(DecoderShape{51, 32, 8, 20, true, false});
  EXPECT_THROW(forward_together({small.get(), large.get()}, at::randn({2, 8})), InputError);
}

TEST(Networks, FusedEncoderMatchesTorchGruInValuesAndGradients) {
  for (const auto& device : devices_to_check()) {
    at::manual_seed(10);
    Encoder encoder(51, 32, 8);
    encoder->to(device);
    expect_same_values_and_gradients(
        encoder, at::randn({3, 20, 51}).to(device),
        [&](const at::Tensor& m) { return encoder->forward_reference(m); }, device.str() + " encoder");
  }
}

TEST(Networks, DiscriminatorScoresAreNonNegative) {
  // Layer 4 ends in a ReLU (supplementary A.3).
  at::manual_seed(8);
  Discriminator discriminator(51);
  EXPECT_GE(discriminator->forward(at::randn({5, 150, 51}) * 3).min().item<float>(), 0.0f);
}

}  // namespace
}  // namespace mm
