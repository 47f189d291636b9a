#include "format/prepared_dataset.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "tests/common/test_environment.h"
#include "tests/format/synthetic_h36m.h"

namespace mm {
namespace {

using ::testing::HasSubstr;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Largest |a - b| over all sequences; sequences must correspond one to one.
double max_abs_difference(const PreparedDataset& a, const PreparedDataset& b) {
  double worst = 0.0;
  for (size_t s = 0; s < a.sequences.size(); ++s) {
    const auto& x = a.sequences[s].normalized.values;
    const auto& y = b.sequences[s].normalized.values;
    for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(double(x[i]) - y[i]));
  }
  return worst;
}

void expect_same_layout(const PreparedDataset& a, const PreparedDataset& b) {
  EXPECT_EQ(a.train_subjects, b.train_subjects);
  EXPECT_EQ(a.test_subjects, b.test_subjects);
  EXPECT_EQ(a.frame_rate, b.frame_rate);
  EXPECT_EQ(a.normalization.mean, b.normalization.mean);
  EXPECT_EQ(a.normalization.stddev, b.normalization.stddev);
  EXPECT_EQ(a.normalization.kept_columns, b.normalization.kept_columns);
  ASSERT_EQ(a.sequences.size(), b.sequences.size());
  for (size_t s = 0; s < a.sequences.size(); ++s) {
    EXPECT_EQ(a.sequences[s].subject, b.sequences[s].subject);
    EXPECT_EQ(a.sequences[s].action, b.sequences[s].action);
    EXPECT_EQ(a.sequences[s].take, b.sequences[s].take);
    EXPECT_EQ(a.sequences[s].phase, b.sequences[s].phase);
    EXPECT_EQ(a.sequences[s].normalized.columns, b.sequences[s].normalized.columns);
    EXPECT_EQ(a.sequences[s].normalized.values.size(), b.sequences[s].normalized.values.size());
  }
}

class SmallPreparedDataset : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_fake_h36m(dir_.path(), {{"S1", "walking", 1, 60}, {"S1", "eating", 2, 41}, {"S5", "walking", 1, 30}});
    SplitOptions options;
    options.train_subjects = {"S1"};
    options.test_subjects = {"S5"};
    data_ = prepare_h36m(dir_.path().string(), options);
    path_ = dir_.file("prepared.mmprep");
    save_prepared_dataset(data_, path_);
  }

  // Loading `bytes` written over the file must fail with a message containing `expected`.
  void expect_rejected(const std::string& bytes, const std::string& expected) {
    write_file_atomically(path_, bytes);
    try {
      load_prepared_dataset(path_);
      ADD_FAILURE() << "accepted a damaged file; expected " << expected;
    } catch (const InputError& error) {
      EXPECT_THAT(error.what(), HasSubstr(path_));
      EXPECT_THAT(error.what(), HasSubstr(expected));
    }
  }

  test::ScratchDir dir_;
  PreparedDataset data_;
  std::string path_;
};

TEST_F(SmallPreparedDataset, FitsNormalizationOnTrainSubjectsOnly) {
  EXPECT_EQ(data_.frame_rate, 25);
  ASSERT_EQ(data_.sequences.size(), 6u);
  // Train frames normalised with train statistics have mean 0 per dimension.
  const auto train = data_.subset({"S1"});
  ASSERT_EQ(train.size(), 4u);
  double sum = 0.0;
  int64_t frames = 0;
  for (const PreparedSequence* s : train) {
    for (int64_t i = 0; i < s->normalized.frame_count(); ++i) sum += s->normalized.frame(i)[0];
    frames += s->normalized.frame_count();
  }
  EXPECT_EQ(frames, 101);
  EXPECT_NEAR(sum / frames, 0.0, 1e-5);
  EXPECT_EQ(data_.subset({"S5"}).size(), 2u);
  EXPECT_TRUE(data_.subset({"S9"}).empty());
}

TEST_F(SmallPreparedDataset, SaveLoadRoundTripWithinQuantisationError) {
  const PreparedDataset loaded = load_prepared_dataset(path_);
  expect_same_layout(data_, loaded);
  EXPECT_LT(max_abs_difference(data_, loaded), 1e-4);
}

TEST_F(SmallPreparedDataset, RejectsMissingFile) {
  EXPECT_THROW(load_prepared_dataset(dir_.file("absent.mmprep")), InputError);
}

TEST_F(SmallPreparedDataset, RejectsTruncatedFileAtAnyLength) {
  const std::string bytes = read_whole_file(path_);
  for (size_t length : {size_t{0}, size_t{5}, size_t{15}, size_t{40}, bytes.size() / 2, bytes.size() - 1}) {
    SCOPED_TRACE("length " + std::to_string(length));
    write_file_atomically(path_, bytes.substr(0, length));
    EXPECT_THROW(load_prepared_dataset(path_), InputError);
  }
}

TEST_F(SmallPreparedDataset, RejectsCorruptPayload) {
  std::string bytes = read_whole_file(path_);
  bytes[bytes.size() - 10] ^= 0x5A;
  expect_rejected(bytes, "corrupt");
}

TEST_F(SmallPreparedDataset, RejectsWrongMagic) {
  std::string bytes = read_whole_file(path_);
  bytes[0] = 'X';
  expect_rejected(bytes, "magic");
}

TEST_F(SmallPreparedDataset, RejectsUnknownVersion) {
  std::string bytes = read_whole_file(path_);
  bytes[8] = 2;
  expect_rejected(bytes, "version 2");
}

TEST_F(SmallPreparedDataset, RejectsTrailingBytes) {
  expect_rejected(read_whole_file(path_) + "x", "unexpected bytes");
}

TEST(PrepareH36m, RejectsSubjectInBothTrainAndTest) {
  SplitOptions options;
  options.test_subjects = {"S1"};
  EXPECT_THROW(prepare_h36m("/nonexistent", options), InputError);
}

// The one slow test: the whole data set, as training will use it.
TEST(PrepareH36m, FullDataSetKeeps51ColumnsAndStoresCompactly) {
  MM_REQUIRE_H36M();
  auto start = std::chrono::steady_clock::now();
  const PreparedDataset data = prepare_h36m(test::data_dir(), SplitOptions{});
  const double prepare_seconds = seconds_since(start);

  // The kept columns are the varying columns of the training subjects listed
  // in the shared skeleton file, minus root translation.
  const std::string json_path = test::shared_dir() + "/data/h36m-skeleton.json";
  if (std::filesystem::exists(json_path)) {
    const auto skeleton = nlohmann::json::parse(read_whole_file(json_path));
    std::vector<int> expected;
    for (int column : skeleton["varying_columns_over_training_subjects"]) {
      if (column > 2) expected.push_back(column);
    }
    EXPECT_EQ(data.normalization.kept_columns, expected);
  }
  EXPECT_EQ(data.normalization.dims(), 51);
  EXPECT_EQ(data.normalization.input_columns(), 99);

  test::ScratchDir dir;
  const std::string path = dir.file("h36m.mmprep");
  start = std::chrono::steady_clock::now();
  save_prepared_dataset(data, path);
  const double save_seconds = seconds_since(start);
  start = std::chrono::steady_clock::now();
  const PreparedDataset loaded = load_prepared_dataset(path);
  const double load_seconds = seconds_since(start);
  const auto bytes = std::filesystem::file_size(path);

  expect_same_layout(data, loaded);
  const double error = max_abs_difference(data, loaded);
  std::cout << "[ full H3.6M ] sequences " << data.sequences.size() << ", prepare " << prepare_seconds
            << " s, save " << save_seconds << " s, file " << bytes / 1048576.0 << " MiB, load " << load_seconds
            << " s, max quantisation error " << error << " std\n";
  RecordProperty("file_bytes", std::to_string(bytes));
  RecordProperty("load_seconds", std::to_string(load_seconds));
  EXPECT_LT(error, 1e-3);
  EXPECT_LT(bytes, 64u << 20);
  EXPECT_LT(load_seconds, 5.0);
}

}  // namespace
}  // namespace mm
