// The recurrences run as CUDA graphs on a GPU (cuda_graph_replay.h): what
// they compute must be what the uncaptured recurrences compute, from the
// capturing call on and for fresh inputs at every replay. The CUDA checks
// run where a GPU is present (the GPU machine, built by
// scripts/build-cuda.sh); without one they are skipped.
#include "model/cuda_graph_replay.h"

#include <gtest/gtest.h>
#include <torch/cuda.h>

#include "model/decoder.h"
#include "model/encoder.h"
#include "model/synthetic_dataset.h"
#include "model/trainer.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

// Puts the process-wide setting back after a test.
class GraphsSetting {
 public:
  ~GraphsSetting() { set_cuda_graphs_enabled(before_); }

 private:
  bool before_ = cuda_graphs_enabled();
};

double relative_difference(const at::Tensor& a, const at::Tensor& b) {
  const double scale = b.abs().max().item<double>() + 1e-6;
  return (a - b).abs().max().item<double>() / scale;
}

TEST(CudaGraphReplay, RunsItsBodyEveryTimeOffCuda) {
  int calls = 0;
  const TensorFunction doubled = [&calls](const std::vector<at::Tensor>& in) {
    ++calls;
    return std::vector<at::Tensor>{in[0] * 2, at::Tensor()};
  };
  for (int i = 0; i < 3; ++i) {
    const auto x = at::full({2}, static_cast<double>(i));
    const auto out = run_as_cuda_graph("test doubling", {x, at::Tensor()}, doubled);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_TRUE(at::equal(out[0], x * 2));
    EXPECT_FALSE(out[1].defined());
  }
  EXPECT_EQ(calls, 3);
}

TEST(CudaGraphReplay, ReplaysWithFreshInputsAndReturnsCopies) {
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  GraphsSetting restore;
  set_cuda_graphs_enabled(true);
  int calls = 0;
  const TensorFunction body = [&calls](const std::vector<at::Tensor>& in) {
    ++calls;
    auto y = in[0];
    for (int i = 0; i < 10; ++i) y = y * in[1] + 1;  // a chain of dependent kernels
    return std::vector<at::Tensor>{y};
  };
  const at::Device cuda(at::kCUDA, 0);
  std::vector<at::Tensor> results, expected;
  for (int i = 0; i < 4; ++i) {
    const auto x = at::randn({5, 3}).to(cuda), a = at::randn({3}).to(cuda);
    results.push_back(run_as_cuda_graph("test chain", {x, a}, body)[0]);
    auto y = x;
    for (int k = 0; k < 10; ++k) y = y * a + 1;
    expected.push_back(y);
  }
  // Call 1 runs the body, call 2 warms up and captures it; calls 3 and 4
  // only replay. Every result stays as it was when later calls ran.
  EXPECT_EQ(calls, 3);
  for (int i = 0; i < 4; ++i) EXPECT_LT(relative_difference(results[i], expected[i]), 1e-6) << "call " << i + 1;
}

// Values and gradients of the encoder and of both decoders run together, as
// in a training step, with the recurrences captured and without, over four
// calls with fresh inputs: uncaptured, capturing, and two replays.
TEST(CudaGraphReplay, RecurrencesMatchUncapturedInValuesAndGradients) {
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  GraphsSetting restore;
  const at::Device cuda(at::kCUDA, 0);
  at::manual_seed(3);
  Encoder encoder(51, 48, 8);
  Decoder rotation(DecoderShape{51, 48, 8, 25, false, false});
  Decoder velocity(DecoderShape{51, 48, 8, 25, true, false});
  encoder->to(cuda);
  rotation->to(cuda);
  velocity->to(cuda);
  std::vector<at::Tensor> parameters = encoder->parameters();
  for (auto* d : {rotation.get(), velocity.get()}) {
    auto p = d->parameters();
    parameters.insert(parameters.end(), p.begin(), p.end());
  }
  auto run = [&](const at::Tensor& clips, const at::Tensor& weights) {
    for (auto& p : parameters) p.mutable_grad() = at::Tensor();
    auto input = clips.clone().requires_grad_(true);
    auto code = encoder->forward(input);
    auto decoded = forward_together({rotation.get(), velocity.get()}, code);
    auto recoded = encoder->forward(at::cat(decoded, 0));  // as L_M re-encodes both outputs
    ((decoded[0] * weights[0]).sum() + (decoded[1] * weights[1]).sum() + recoded.pow(2).sum()).backward();
    std::vector<at::Tensor> results{decoded[0].detach(), decoded[1].detach(), recoded.detach(), input.grad()};
    for (auto& p : parameters) results.push_back(p.grad().clone());
    return results;
  };
  for (int call = 1; call <= 4; ++call) {
    const auto clips = at::randn({4, 25, 51}).to(cuda), weights = at::randn({2, 4, 25, 51}).to(cuda);
    set_cuda_graphs_enabled(false);
    const auto uncaptured = run(clips, weights);
    set_cuda_graphs_enabled(true);
    const auto captured = run(clips, weights);
    ASSERT_EQ(captured.size(), uncaptured.size());
    for (size_t i = 0; i < captured.size(); ++i) {
      EXPECT_LT(relative_difference(captured[i], uncaptured[i]), 1e-5)
          << "call " << call << ", tensor " << i << " (0-2 outputs, 3 input gradient, then parameter gradients)";
    }
  }
}

// Whole training steps: two runs from the same seed, one with graphs and
// one without, take the same losses and end at the same weights.
TEST(CudaGraphReplay, TrainingStepsMatchUncaptured) {
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  GraphsSetting restore;
  const at::Device cuda(at::kCUDA, 0);
  const PreparedDataset data = synthetic_h36m_dataset();
  const TrainConfig config = test::tiny_config("DKGM");
  Trainer uncaptured(config, data, cuda), captured(config, data, cuda);
  for (int step = 1; step <= 4; ++step) {
    set_cuda_graphs_enabled(false);
    const LossValues expected = uncaptured.step();
    set_cuda_graphs_enabled(true);
    const LossValues found = captured.step();
    for (const auto& [term, value] : expected) {
      EXPECT_NEAR(found.at(term), value, 1e-4 * (std::abs(value) + 1e-3)) << "step " << step << ", " << term;
    }
  }
  const auto a = uncaptured.model().generator_parameters(), b = captured.model().generator_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_LT(relative_difference(b[i], a[i]), 1e-4) << "parameter " << i;
}

}  // namespace
}  // namespace mm
