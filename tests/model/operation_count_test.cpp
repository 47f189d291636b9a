// The bench's count of tensor operations: what a step issues, not how the
// operators are built inside.
#include <gtest/gtest.h>

#include <ATen/ATen.h>

#include "model/decoder.h"
#include "model/tool/operation_count.h"

namespace mm::tool {
namespace {

TEST(OperationCount, CountsEachOperationOnceHoweverItIsBuilt) {
  const auto a = at::randn({4, 8}), b = at::randn({8, 3}), bias = at::randn({3});
  EXPECT_EQ(count_operations([&] { (void)(a + 1); }), 1);
  // addmm broadcasts its bias and resolves conjugation inside: still one.
  EXPECT_EQ(count_operations([&] { (void)at::addmm(bias, a, b); }), 1);
  EXPECT_EQ(count_operations([&] { (void)at::sigmoid(at::addmm(bias, a, b)); }), 2);
}

TEST(OperationCount, LeavesOutViewsAllocationsAndConversionsThatCopyNothing) {
  const auto a = at::randn({4, 8});
  EXPECT_EQ(count_operations([&] { (void)a.narrow(0, 1, 2).reshape({-1}).unsqueeze(0).t(); }), 0);
  EXPECT_EQ(count_operations([&] { (void)at::empty({16}); }), 0);
  EXPECT_EQ(count_operations([&] { (void)a.to(at::kFloat).contiguous(); }), 0);
  // A conversion or a reshape that must copy is an operation.
  EXPECT_EQ(count_operations([&] { (void)a.to(at::kDouble); }), 1);
  EXPECT_EQ(count_operations([&] { (void)a.t().reshape({-1}); }), 1);
}

TEST(OperationCount, CountsTheBackwardPass) {
  const auto w = at::randn({8, 3}).requires_grad_(true);
  const auto x = at::randn({4, 8});
  const auto loss = at::mm(x, w).sum();
  EXPECT_GT(count_operations([&] { loss.backward(); }), 0);
}

// Operations per time step of both decoders, forward and backward, from the
// difference between two clip lengths (what does not repeat per step cancels).
double operations_per_step(bool together) {
  auto per_clip = [&](int frames) {
    Decoder rotation(DecoderShape{51, 16, 8, frames, false, false});
    Decoder velocity(DecoderShape{51, 16, 8, frames, true, false});
    const auto z = at::randn({2, 8});
    return count_operations([&] {
      auto outputs = together ? forward_together({rotation.get(), velocity.get()}, z)
                              : std::vector<at::Tensor>{rotation->forward(z), velocity->forward(z)};
      (outputs[0].sum() + outputs[1].sum()).backward();
    });
  };
  return (per_clip(30) - per_clip(10)) / 20.0;
}

// The training step runs both decoders as one recurrence to issue fewer
// operations per step (on a GPU, fewer kernel launches).
TEST(OperationCount, DecodersRunTogetherIssueFewerOperationsPerStep) {
  const double together = operations_per_step(true), apart = operations_per_step(false);
  RecordProperty("together", std::to_string(together));
  RecordProperty("apart", std::to_string(apart));
  EXPECT_LT(together, 0.75 * apart) << "per step: together " << together << ", one after the other " << apart;
}

}  // namespace
}  // namespace mm::tool
