#include "format/h36m_corpus.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/input_error.h"
#include "tests/common/test_environment.h"
#include "tests/format/synthetic_h36m.h"

namespace mm {
namespace {

using ::testing::HasSubstr;

TEST(H36mCorpus, SplitsEveryFileIntoDownsampledPhasesSortedBySubjectActionTakePhase) {
  test::ScratchDir dir;
  test::write_fake_h36m(dir.path(), {{"S11", "eating", 1, 8}, {"S5", "walking", 2, 7}, {"S5", "eating", 2, 4},
                                     {"S5", "eating", 1, 6}});
  const auto corpus = load_h36m_corpus(dir.path().string(), {"S11", "S5"}, 2);
  ASSERT_EQ(corpus.size(), 8u);
  std::vector<std::string> order;
  for (const auto& s : corpus) {
    order.push_back(s.subject + "/" + s.action + "_" + std::to_string(s.take) + "#" + std::to_string(s.phase));
  }
  EXPECT_EQ(order, (std::vector<std::string>{"S5/eating_1#0", "S5/eating_1#1", "S5/eating_2#0", "S5/eating_2#1",
                                             "S5/walking_2#0", "S5/walking_2#1", "S11/eating_1#0",
                                             "S11/eating_1#1"}));
  EXPECT_EQ(corpus[4].frames.frame_count(), 4);  // frames 0, 2, 4, 6 of 7
  EXPECT_EQ(corpus[5].frames.frame_count(), 3);  // frames 1, 3, 5
}

TEST(H36mCorpus, AcceptsDatasetFolderItselfOrAParent) {
  test::ScratchDir dir;
  test::write_fake_h36m(dir.path(), {{"S1", "walking", 1, 4}});
  for (const auto& root : {dir.path(), dir.path() / "h3.6m", dir.path() / "h3.6m" / "dataset"}) {
    EXPECT_EQ(load_h36m_corpus(root.string(), {"S1"}, 1).size(), 1u) << root;
  }
}

TEST(H36mCorpus, MissingSubjectFolderIsInputError) {
  test::ScratchDir dir;
  test::write_fake_h36m(dir.path(), {{"S1", "walking", 1, 4}});
  try {
    load_h36m_corpus(dir.path().string(), {"S1", "S2"});
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_THAT(error.what(), HasSubstr("S2"));
  }
}

TEST(H36mCorpus, MalformedFileErrorNamesTheFile) {
  test::ScratchDir dir;
  test::write_fake_h36m(dir.path(), {{"S1", "walking", 1, 4}});
  std::ofstream(dir.path() / "h3.6m" / "dataset" / "S1" / "eating_2.txt") << "1,2,3\n";
  try {
    load_h36m_corpus(dir.path().string(), {"S1"});
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_THAT(error.what(), HasSubstr("eating_2.txt:1: expected 99 values, found 3"));
  }
}

TEST(H36mCorpus, RealSubjectSkipsFilesAbsentFromTheCopy) {
  MM_REQUIRE_H36M();
  const auto corpus = load_h36m_corpus(test::data_dir(), {"S5"}, 2);
  // S5 misses 6 of its 30 files in this copy (h36m-MANIFEST.tsv).
  EXPECT_EQ(corpus.size(), 24u * 2u);
  const auto walking = std::find_if(corpus.begin(), corpus.end(), [](const MotionSequence& s) {
    return s.action == "walking" && s.take == 1 && s.phase == 1;
  });
  ASSERT_NE(walking, corpus.end());
  EXPECT_EQ(walking->frames.frame_count(), 1500);  // 3000 frames at 50 Hz
}

}  // namespace
}  // namespace mm
