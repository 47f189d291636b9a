// A test suite on the shipped default model, loaded once for all its tests
// (loading takes about a second) and freed after them. Derive a fixture from
// it and read `model_`; without the H3.6M copy it stays null and the tests
// skip or fail as test_environment.h says.
#pragma once

#include <gtest/gtest.h>

#include "model/default_model.h"
#include "model/motion_manifold.h"
#include "tests/common/test_environment.h"

namespace mm::test {

class ShippedModelSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!has_h36m()) return;
    model_ = new MotionManifold(MotionManifold::load(default_model_dir()));
  }
  static void TearDownTestSuite() {
    delete model_;
    model_ = nullptr;
  }
  static inline MotionManifold* model_ = nullptr;
};

}  // namespace mm::test
