// Specification of BVH reading and writing (format/bvh_file.h) and of the
// H3.6M <-> BVH conversion (format/h36m_bvh.h).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "tests/common/test_environment.h"
#include "tests/format/h36m_pose.h"

namespace mm {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

constexpr double kToleranceMm = 0.1;

MotionFrames s5_clip(const std::string& name, int64_t max_frames = 400) {
  MotionFrames motion = read_motion_text((test::h36m_dataset_dir() / "S5" / name).string());
  if (motion.frame_count() > max_frames) motion.values.resize(static_cast<size_t>(max_frames) * motion.columns);
  return motion;
}

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// Largest distance between the joint positions (root-relative) of two
// 99-column frames.
double pose_error_mm(const float* a, const float* b) {
  const auto pa = test::h36m_positions_mm(a), pb = test::h36m_positions_mm(b);
  double worst = 0;
  for (size_t j = 0; j < pa.size(); ++j) worst = std::max(worst, distance(pa[j], pb[j]));
  return worst;
}

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

// A small synthetic motion: random rotations up to pi on every joint with
// rotation data, root moving 5 mm a frame.
MotionFrames random_motion(int frames, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> angle(-1.8f, 1.8f);
  MotionFrames motion;
  motion.values.assign(static_cast<size_t>(frames) * kH36mColumns, 0.0f);
  for (int f = 0; f < frames; ++f) {
    float* frame = motion.frame(f);
    if (f > 0) frame[0] = 5.0f, frame[2] = -3.0f;
    for (int c = 3; c < kH36mColumns; ++c) frame[c] = angle(random);
  }
  return motion;
}

TEST(RotationMatrix, EulerAnglesReproduceTheMatrixInEveryOrder) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  for (const char* name : {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"}) {
    EulerOrder order;
    ASSERT_TRUE(EulerOrder::parse(name, &order));
    EXPECT_EQ(order.name(), name);
    for (int trial = 0; trial < 200; ++trial) {
      Vec3 e{value(random), value(random), value(random)};
      if (trial == 0) e = {0, 0, 0};
      Mat3 m = expmap_to_matrix(e);
      if (trial == 1) m = euler_degrees_to_matrix(order, {30, 90, 10});  // gimbal lock
      if (trial == 2) m = euler_degrees_to_matrix(order, {-20, -90, 45});
      const Mat3 back = euler_degrees_to_matrix(order, matrix_to_euler_degrees(order, m));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) ASSERT_NEAR(back[i][j], m[i][j], 1e-9) << name << " trial " << trial;
    }
  }
  EulerOrder order;
  EXPECT_FALSE(EulerOrder::parse("XXY", &order));
  EXPECT_FALSE(EulerOrder::parse("XY", &order));
}

TEST(RotationMatrix, ExpmapRoundTripsUpToPi) {
  for (const Vec3& e : std::vector<Vec3>{{0, 0, 0}, {1e-9, 0, 0}, {0.3, -0.2, 1.0}, {0, 3.14159265358979, 0}, {-2, 1, 1.5}}) {
    const Mat3 m = expmap_to_matrix(e);
    const Mat3 back = expmap_to_matrix(matrix_to_expmap(m));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(back[i][j], m[i][j], 1e-12);
  }
}

TEST(H36mBvh, ExportedFileGivesOurJointPositionsOnRealClips) {
  MM_REQUIRE_H36M();
  for (const char* name : {"walking_1.txt", "eating_2.txt", "sitting_1.txt"}) {
    SCOPED_TRACE(name);
    const MotionFrames motion = s5_clip(name);
    const BvhFile file = parse_bvh_text(h36m_motion_to_bvh_text(motion, 50.0), "exported.bvh");
    ASSERT_EQ(file.frame_count(), motion.frame_count());
    EXPECT_DOUBLE_EQ(file.frame_time_s, 0.02);
    EXPECT_EQ(file.joints.size(), 32u);
    EXPECT_EQ(file.named_joint_count(), 25);
    Vec3 root{0, 0, 0};
    double worst = 0;
    for (int64_t f = 0; f < motion.frame_count(); ++f) {
      for (int k = 0; k < 3; ++k) root[k] += motion.frame(f)[k];
      const auto ours = test::h36m_positions_mm(motion.frame(f));
      const auto bvh = bvh_world_positions(file, f);
      for (size_t j = 0; j < ours.size(); ++j) {
        worst = std::max(worst, distance(bvh[j], {ours[j][0] + root[0], ours[j][1] + root[1], ours[j][2] + root[2]}));
      }
    }
    EXPECT_LT(worst, kToleranceMm);
  }
}

TEST(H36mBvh, RoundTripOfRealClipsReproducesJointPositionsAt25Hz) {
  MM_REQUIRE_H36M();
  for (const char* name : {"walking_1.txt", "greeting_1.txt", "phoning_2.txt", "takingphoto_1.txt"}) {
    SCOPED_TRACE(name);
    const MotionFrames motion = s5_clip(name);
    const MotionFrames back = h36m_motion_from_bvh_text(h36m_motion_to_bvh_text(motion, 50.0), name);
    ASSERT_EQ(back.columns, kH36mColumns);
    ASSERT_EQ(back.frame_count(), (motion.frame_count() - 1) / 2 + 1);  // the even 50 Hz frames
    double worst = 0;
    for (int64_t k = 0; k < back.frame_count(); ++k) worst = std::max(worst, pose_error_mm(back.frame(k), motion.frame(2 * k)));
    EXPECT_LT(worst, kToleranceMm);
    // Root: per-frame changes at 25 Hz are sums of two 50 Hz changes.
    for (int64_t k = 1; k < back.frame_count(); ++k) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_NEAR(back.frame(k)[c], motion.frame(2 * k - 1)[c] + motion.frame(2 * k)[c], 1e-3) << "frame " << k;
      }
    }
  }
}

TEST(H36mBvh, AClipAt25HzKeepsEveryFrameAndItsRootChanges) {
  MM_REQUIRE_H36M();
  const MotionFrames motion = split_phases(s5_clip("walking_2.txt"), 2)[0];
  const std::string text = h36m_motion_to_bvh_text(motion, 25.0);
  EXPECT_THAT(text, HasSubstr("Frame Time: 0.04\n"));
  const MotionFrames back = h36m_motion_from_bvh_text(text, "walk.bvh");
  ASSERT_EQ(back.frame_count(), motion.frame_count());
  for (int64_t k = 0; k < back.frame_count(); ++k) {
    ASSERT_LT(pose_error_mm(back.frame(k), motion.frame(k)), kToleranceMm) << k;
    if (k > 0) {
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(back.frame(k)[c], motion.frame(k)[c], 1e-3);
    }
  }
}

TEST(H36mBvh, EveryRotationOrderAndSixChannelsReadBack) {
  const MotionFrames motion = random_motion(20, 11);
  for (const char* name : {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"}) {
    for (bool six : {false, true}) {
      SCOPED_TRACE(std::string(name) + (six ? " 6 channels" : " 3 channels"));
      H36mBvhExportOptions options;
      ASSERT_TRUE(EulerOrder::parse(name, &options.rotation_order));
      options.position_channels_on_every_joint = six;
      const std::string text = h36m_motion_to_bvh_text(motion, 25.0, options);
      const BvhFile file = parse_bvh_text(text, "x.bvh");
      EXPECT_EQ(file.joints[1].channels.size(), six ? 6u : 3u);
      const MotionFrames back = h36m_motion_from_bvh(file, "x.bvh");
      ASSERT_EQ(back.frame_count(), 20);
      for (int64_t k = 0; k < 20; ++k) ASSERT_LT(pose_error_mm(back.frame(k), motion.frame(k)), kToleranceMm);
    }
  }
}

TEST(H36mBvh, MixedOrdersPerJointCrlfAndAnyFrameTimeAreAccepted) {
  const MotionFrames motion = random_motion(101, 5);  // 4 s at 25 Hz
  // Export at "100 Hz" (frame time 0.01), then give joints different orders
  // by converting frame by frame through the generic file.
  H36mBvhExportOptions xyz;
  EulerOrder::parse("XYZ", &xyz.rotation_order);
  BvhFile a = h36m_motion_to_bvh(motion, 100.0);
  const BvhFile b = h36m_motion_to_bvh(motion, 100.0, xyz);
  // Odd joints take XYZ from b.
  const auto first = a.first_channels();
  for (size_t j = 1; j < a.joints.size(); j += 2) {
    if (a.joints[j].end_site) continue;
    a.joints[j].channels = b.joints[j].channels;
    for (int64_t f = 0; f < a.frame_count(); ++f) {
      for (int c = 0; c < 3; ++c) a.values[f * a.channel_count() + first[j] + c] = b.values[f * b.channel_count() + first[j] + c];
    }
  }
  const std::string crlf = replace_all(write_bvh_text(a), "\n", "\r\n");
  const MotionFrames back = h36m_motion_from_bvh_text(crlf, "crlf.bvh");
  // 100 frames of 0.01 s = 1 s: 26 frames at 25 Hz, frame k from source 4k.
  ASSERT_EQ(back.frame_count(), 26);
  for (int64_t k = 0; k < 26; ++k) ASSERT_LT(pose_error_mm(back.frame(k), motion.frame(4 * k)), kToleranceMm) << k;
}

TEST(H36mBvh, ResamplingTakesTheNearestFrame) {
  const MotionFrames motion = random_motion(30, 2);
  // At 30 Hz, 25 Hz frame k (time k/25) is nearest to source frame round(1.2 k).
  const MotionFrames back = h36m_motion_from_bvh_text(h36m_motion_to_bvh_text(motion, 30.0), "30hz.bvh");
  ASSERT_EQ(back.frame_count(), 25);  // 29 / 30 s -> frames 0..24
  for (int64_t k = 0; k < 25; ++k) {
    const int64_t source = static_cast<int64_t>(std::floor(1.2 * k + 0.5));
    ASSERT_LT(pose_error_mm(back.frame(k), motion.frame(source)), kToleranceMm) << k;
  }
}

TEST(H36mBvh, AnotherHierarchyIsRefusedNamingWhatDiffers) {
  const std::string text = h36m_motion_to_bvh_text(random_motion(3, 1), 25.0);
  EXPECT_THAT(error_of([&] { h36m_motion_from_bvh_text(replace_all(text, "JOINT LeftLeg", "JOINT LeftKnee"), "k.bvh"); }),
              AllOf(HasSubstr("k.bvh: not the H3.6M skeleton"), HasSubstr("missing joints: LeftLeg"),
                    HasSubstr("unexpected joints: LeftKnee")));
  // Head moved under Spine1 (Neck's sibling): swap the names Neck and Head.
  std::string swapped = replace_all(replace_all(replace_all(text, "JOINT Neck", "JOINT @"), "JOINT Head", "JOINT Neck"),
                                    "JOINT @", "JOINT Head");
  EXPECT_THAT(error_of([&] { h36m_motion_from_bvh_text(swapped, "s.bvh"); }),
              AllOf(HasSubstr("a different parent"), HasSubstr("Neck's parent is Head, expected Spine1")));
  // A joint removed: the End Site under Head.
  BvhFile fewer = parse_bvh_text(text, "f.bvh");
  EXPECT_THAT(error_of([&] {
                BvhFile copy = fewer;
                copy.joints.erase(copy.joints.begin() + 15);  // Head's End Site
                for (auto& joint : copy.joints) if (joint.parent > 15) --joint.parent;
                h36m_motion_from_bvh(copy, "f.bvh");
              }),
              AllOf(HasSubstr("it has 25 joints and 6 end sites"), HasSubstr("missing joints: Head_End (or an End Site under Head)")));
}

TEST(H36mBvh, LeavesMayBeJoints) {
  // A writer that keeps all 32 joints, leaves with channels and end sites.
  const MotionFrames motion = random_motion(4, 8);
  BvhFile file = h36m_motion_to_bvh(motion, 25.0);
  const Skeleton h36m = Skeleton::h36m();
  BvhFile full;
  full.frame_time_s = file.frame_time_s;
  std::vector<int> index;
  for (size_t j = 0; j < file.joints.size(); ++j) {
    BvhJoint joint = file.joints[j];
    const bool leaf = joint.end_site;
    if (leaf) {
      joint.end_site = false;
      joint.name = h36m.joints[j].name;
      joint.channels = file.joints[1].channels;
    }
    joint.parent = joint.parent < 0 ? -1 : index[joint.parent];
    index.push_back(static_cast<int>(full.joints.size()));
    full.joints.push_back(joint);
    if (leaf) {
      BvhJoint end;
      end.end_site = true;
      end.parent = index.back();
      full.joints.push_back(end);
    }
  }
  const auto first = file.first_channels();
  for (int64_t f = 0; f < file.frame_count(); ++f) {
    for (size_t j = 0; j < file.joints.size(); ++j) {
      if (file.joints[j].end_site) {
        full.values.insert(full.values.end(), {0.0, 0.0, 0.0});
      } else {
        for (size_t c = 0; c < file.joints[j].channels.size(); ++c) full.values.push_back(file.values[f * file.channel_count() + first[j] + c]);
      }
    }
  }
  const MotionFrames back = h36m_motion_from_bvh_text(write_bvh_text(full), "full.bvh");
  ASSERT_EQ(back.frame_count(), 4);
  for (int64_t k = 0; k < 4; ++k) ASSERT_LT(pose_error_mm(back.frame(k), motion.frame(k)), kToleranceMm);
}

// The CMU dance set: another skeleton, 43 joints in cm at 120 Hz.
class CmuDance : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string archive = test::shared_dir() + "/data/cmu-dance-bvh.tar.xz";
    if (!std::filesystem::exists(archive)) return;
    dir_ = new test::ScratchDir();
    const std::string command = "tar xJf '" + archive + "' -C '" + dir_->path().string() + "'";
    if (std::system(command.c_str()) != 0) FAIL() << command << " failed";
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::vector<std::string> files() {
    std::vector<std::string> paths;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir_->path())) {
      if (entry.path().extension() == ".bvh") paths.push_back(entry.path().string());
    }
    std::sort(paths.begin(), paths.end());
    return paths;
  }
  void SetUp() override {
    if (dir_ == nullptr) FAIL() << test::shared_dir() << "/data/cmu-dance-bvh.tar.xz not found";
  }
  static test::ScratchDir* dir_;
};
test::ScratchDir* CmuDance::dir_ = nullptr;

TEST_F(CmuDance, EveryFileImportsAsAGenericHierarchy) {
  const auto paths = files();
  ASSERT_EQ(paths.size(), 15u);
  for (const auto& path : paths) {
    SCOPED_TRACE(path);
    const BvhFile file = read_bvh_file(path);
    EXPECT_EQ(file.named_joint_count(), 43);
    EXPECT_EQ(file.joints.size(), 43u + 14u);
    EXPECT_NEAR(file.frame_time_s, 1.0 / 120.0, 1e-6);
    EXPECT_GE(file.frame_count(), 1317);
    EXPECT_EQ(file.joints[0].channels.size(), 6u);
    EXPECT_EQ(file.channel_count(), 6 + 42 * 3);
    const Skeleton skeleton = bvh_skeleton(file, "cmu-dance", 10.0);
    EXPECT_EQ(skeleton.joint_count(), 57);
    // The skeleton is valid by Skeleton's own rules: it survives its JSON.
    const Skeleton again = Skeleton::from_json_text(skeleton.to_json_text(), "cmu");
    EXPECT_EQ(again.joint_count(), 57);
    EXPECT_EQ(again.joints[1].name, "abdomen");
    EXPECT_DOUBLE_EQ(again.joints[1].offset_mm[1], 206.881);
    // Written and read back, it is the same file.
    const BvhFile back = parse_bvh_text(write_bvh_text(file), "again.bvh");
    ASSERT_EQ(back.values.size(), file.values.size());
    for (size_t i = 0; i < file.values.size(); i += 97) ASSERT_NEAR(back.values[i], file.values[i], 1e-6);
  }
}

TEST_F(CmuDance, IsRefusedAsH36mWithAClearMessage) {
  const std::string path = files().front();
  EXPECT_THAT(error_of([&] { h36m_motion_from_bvh(read_bvh_file(path), path); }),
              AllOf(HasSubstr(path + ": not the H3.6M skeleton (h36m-32): it has 43 joints and 14 end sites"),
                    HasSubstr("missing joints: Hips"), HasSubstr("unexpected joints: ")));
}

// --- Malformed files: an InputError with the file and line, never a crash.

const char* const kTiny =
    "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
    "\tJOINT Leg\n\t{\n\t\tOFFSET 0 -10 0\n\t\tCHANNELS 3 Zrotation Yrotation Xrotation\n\t\tEnd Site\n\t\t{\n"
    "\t\t\tOFFSET 0 -10 0\n\t\t}\n\t}\n}\nMOTION\nFrames: 2\nFrame Time: 0.04\n"
    "0 0 0 0 0 0 10 20 30\n1 2 3 4 5 6 7 8 9\n";

TEST(BvhFile, ParsesASmallFile) {
  const BvhFile file = parse_bvh_text(std::string(kTiny), "tiny.bvh");
  ASSERT_EQ(file.joints.size(), 3u);
  EXPECT_TRUE(file.joints[2].end_site);
  EXPECT_EQ(file.frame_count(), 2);
  EXPECT_EQ(file.values[15], 7.0);
  const auto positions = bvh_world_positions(file, 1);
  EXPECT_NEAR(positions[0][0], 1.0, 1e-12);
  EXPECT_EQ(write_bvh_text(parse_bvh_text(write_bvh_text(file), "a")), write_bvh_text(file));
}

TEST(BvhFile, MalformedFilesAreRefusedWithFileAndLine) {
  const std::string tiny = kTiny;
  auto error = [](const std::string& text) { return error_of([&] { parse_bvh_text(text, "bad.bvh"); }); };
  EXPECT_THAT(error(""), HasSubstr("bad.bvh: empty file"));
  EXPECT_THAT(error(tiny.substr(0, tiny.find("MOTION"))), HasSubstr("bad.bvh: no MOTION section"));
  EXPECT_THAT(error(replace_all(tiny, "1 2 3 4", "1 2 nan 4")), AllOf(HasSubstr("bad.bvh:20:"), HasSubstr("\"nan\"")));
  EXPECT_THAT(error(replace_all(tiny, "1 2 3 4", "1 2 1e300 4")), AllOf(HasSubstr("bad.bvh:20:"), HasSubstr("out of range")));
  EXPECT_THAT(error(replace_all(tiny, "1 2 3 4", "1 2 3")), AllOf(HasSubstr("bad.bvh:20: 8 values in frame 2, expected 9")));
  EXPECT_THAT(error(replace_all(tiny, "10 20 30", "10 20 30 40")), HasSubstr("bad.bvh:19: more than 9 values"));
  EXPECT_THAT(error(replace_all(tiny, "CHANNELS 3", "CHANNELS 4")), HasSubstr("bad.bvh:10: channel \"End\" of joint Leg"));
  EXPECT_THAT(error(replace_all(tiny, "CHANNELS 3", "CHANNELS 7")), HasSubstr("bad.bvh:9: channel count 7"));
  EXPECT_THAT(error(replace_all(tiny, "Frames: 2", "Frames: 2000")),
              HasSubstr("bad.bvh: \"Frames:\" declares 2000 frames but the file holds 2"));
  // A declared length past the longest take is refused before any frame is read.
  EXPECT_THAT(error(replace_all(tiny, "Frames: 2", "Frames: 2000000000000")),
              HasSubstr("bad.bvh:18: 2000000000000 frames of 0.04 s make 2000000000000 frames at 25 Hz, more than"));
  EXPECT_THAT(error(replace_all(tiny, "Frames: 2", "Frames: 1")), HasSubstr("bad.bvh:20: more frames than the 1"));
  EXPECT_THAT(error(replace_all(tiny, "0.04", "0")), HasSubstr("bad.bvh:18: frame time 0 s"));
  EXPECT_THAT(error(replace_all(tiny, "0.04", "inf")), HasSubstr("bad.bvh:18:"));
  EXPECT_THAT(error(replace_all(tiny, "JOINT Leg", "JOINT Hips")), HasSubstr("joint name \"Hips\" appears twice"));
  EXPECT_THAT(error(replace_all(tiny, "Yrotation Xrotation\n\t\tEnd", "Yrotation Yrotation\n\t\tEnd")),
              HasSubstr("bad.bvh:9: channel Yrotation of joint Leg appears twice"));
}

TEST(BvhFile, DeepNestingIsBoundedWithoutRecursion) {
  std::string text = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n";
  for (int i = 0; i < 200000; ++i) text += "JOINT j" + std::to_string(i) + " { OFFSET 0 1 0 CHANNELS 0\n";
  EXPECT_THAT(error_of([&] { parse_bvh_text(text, "deep.bvh"); }), HasSubstr("more than 1024 joints"));
  // Just below the bound it parses, and writes back without recursion.
  std::string ok = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n";
  for (int i = 0; i < 1022; ++i) ok += "JOINT j" + std::to_string(i) + " { OFFSET 0 1 0 CHANNELS 0\n";
  ok += "End Site { OFFSET 0 0 0 }\n" + [] { std::string s; for (int i = 0; i < 1023; ++i) s += "}\n"; return s; }() + "\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0\n";
  const BvhFile file = parse_bvh_text(ok, "ok.bvh");
  EXPECT_EQ(file.joints.size(), 1024u);
  EXPECT_NEAR(bvh_world_positions(file, 0).back()[1], 1022.0, 1e-6);
  EXPECT_NO_THROW(write_bvh_text(file));
}

TEST(BvhFile, NoPrefixOrMutationOfAFileCrashes) {
  const MotionFrames motion = random_motion(3, 4);
  const std::string text = h36m_motion_to_bvh_text(motion, 25.0);
  int accepted = 0;
  auto attempt = [&](const std::string& candidate) {
    try {
      const BvhFile file = parse_bvh_text(candidate, "fuzz.bvh");
      (void)h36m_motion_from_bvh(file, "fuzz.bvh");
      ++accepted;
    } catch (const InputError&) {
    }
  };
  for (size_t cut = 0; cut < text.size(); cut += 7) attempt(text.substr(0, cut));
  std::mt19937 random(9);
  const std::string alphabet = "0123456789.-e{}\n\r\t ABCDEFGHIJKLMNOPQRSTUVWXYZnanif:";
  for (int trial = 0; trial < 3000; ++trial) {
    std::string mutated = text;
    const int edits = 1 + static_cast<int>(random() % 4);
    for (int e = 0; e < edits; ++e) {
      const size_t at = random() % mutated.size();
      switch (random() % 3) {
        case 0: mutated[at] = alphabet[random() % alphabet.size()]; break;
        case 1: mutated.erase(at, 1 + random() % 20); break;
        default: mutated.insert(at, std::string(1 + random() % 5, alphabet[random() % alphabet.size()]));
      }
      if (mutated.empty()) mutated = "x";
    }
    attempt(mutated);
  }
  EXPECT_GT(accepted, 0);  // some edits (a digit) keep a valid file
}

// What a file will cost to resample is checked at its "Frame Time:" line,
// before any frame is read: a frame time outside 1 to 1000 frames a
// second, and a declared length beyond the limit (the longest take by
// default), each named with the line and the value.
TEST(H36mBvh, LongFrameTimesAndTakesAreRefusedBeforeTheFramesAreRead) {
  const std::string text = h36m_motion_to_bvh_text(random_motion(20, 1), 25.0);
  const size_t time_line = static_cast<size_t>(std::count(text.begin(), text.begin() + text.find("Frame Time"), '\n')) + 1;
  const std::string at = "slow.bvh:" + std::to_string(time_line) + ": ";
  for (const std::string frame_time : {"3600", "1.5", "0.0005", "-0.04", "0"}) {
    EXPECT_THAT(error_of([&] { parse_bvh_text(replace_all(text, "Frame Time: 0.04", "Frame Time: " + frame_time), "slow.bvh"); }),
                HasSubstr(at + "frame time " + frame_time + " s, expected 0.001 to 1 s (1 to 1000 frames a second)"));
  }
  EXPECT_THAT(error_of([&] { parse_bvh_text(replace_all(text, "Frame Time: 0.04", "Frame Time: nan"), "slow.bvh"); }),
              HasSubstr(at + "\"nan\" is out of range"));
  for (const std::string frame_time : {"1", "0.001"}) {
    EXPECT_NO_THROW(parse_bvh_text(replace_all(text, "Frame Time: 0.04", "Frame Time: " + frame_time), "ok.bvh"));
  }
  // 20 frames declared as 2,000,000 (22 h): refused at the frame time's line
  // for its length, not at the end for the missing frames.
  const std::string long_take = replace_all(text, "Frames: 20", "Frames: 2000000");
  EXPECT_THAT(error_of([&] { parse_bvh_text(long_take, "slow.bvh"); }),
              HasSubstr(at + "2000000 frames of 0.04 s make 2000000 frames at 25 Hz, more than the 1000000 of the "
                             "longest take (11.1 h)"));
  BvhFrameLimit clip;
  clip.frames = 10;
  clip.name = "a test's clip";
  EXPECT_THAT(error_of([&] { parse_bvh_text(text, "slow.bvh", clip); }),
              HasSubstr(at + "20 frames of 0.04 s make 20 frames at 25 Hz, more than the 10 of a test's clip"));
  EXPECT_THAT(error_of([&] { skeleton_motion_from_bvh(Skeleton::h36m(), parse_bvh_text(text, "x.bvh"), "x.bvh", clip); }),
              HasSubstr("x.bvh: 20 frames of 0.04 s make 20 frames at 25 Hz, more than the 10 of a test's clip"));
  EXPECT_EQ(bvh_imported_frame_count(12, 3600), 990001);
  EXPECT_EQ(bvh_imported_frame_count(12, 1), 276);
  EXPECT_EQ(bvh_imported_frame_count(300, 0.02), 150);
  EXPECT_EQ(bvh_imported_frame_count(0, 0.04), 0);
  EXPECT_THAT(error_of([&] { h36m_motion_to_bvh(random_motion(2, 1), 2000.0); }), HasSubstr("expected 1 to 1000 Hz"));
  std::string far = h36m_motion_to_bvh_text(random_motion(2, 1), 25.0);
  BvhFile file = parse_bvh_text(far, "far.bvh");
  file.values[file.channel_count()] = 9e6;  // root x of frame 1
  EXPECT_THAT(error_of([&] { h36m_motion_from_bvh(file, "far.bvh"); }), HasSubstr("far.bvh: the root moves"));
}

// A window costs what the window does: frames computed from its first
// file frame only, equal to the import of the file cut there.
TEST(H36mBvh, AWindowIsTheImportOfTheFileCutAtItsFirstFrame) {
  const BvhFile file = h36m_motion_to_bvh(random_motion(90, 3), 50.0);  // 89 frames of 0.02 s: 45 at 25 Hz
  BvhFile cut = file;
  const auto channels = static_cast<size_t>(file.channel_count());
  cut.values.erase(cut.values.begin(), cut.values.begin() + static_cast<std::ptrdiff_t>(7 * channels));
  const MotionFrames whole_cut = skeleton_motion_from_bvh(Skeleton::h36m(), cut, "cut.bvh");
  const MotionFrames window = skeleton_motion_window_from_bvh(Skeleton::h36m(), file, "file.bvh", 7, 20);
  ASSERT_EQ(window.frame_count(), 20);
  EXPECT_EQ(window.values, std::vector<float>(whole_cut.values.begin(), whole_cut.values.begin() + 20 * 99));
  EXPECT_THAT(error_of([&] { skeleton_motion_window_from_bvh(Skeleton::h36m(), file, "file.bvh", 7, 43); }),
              HasSubstr("file.bvh: from frame 7 it makes 42 frames at 25 Hz, fewer than the 43"));
}

TEST(H36mBvh, ExportRefusesWhatIsNotAnH36mMotion) {
  MotionFrames wrong;
  wrong.columns = 10;
  wrong.values.assign(20, 0.0f);
  EXPECT_THAT(error_of([&] { h36m_motion_to_bvh(wrong, 25.0); }), HasSubstr("10 columns"));
  MotionFrames empty;
  EXPECT_THAT(error_of([&] { h36m_motion_to_bvh(empty, 25.0); }), HasSubstr("no frames"));
  MotionFrames bad = random_motion(2, 1);
  bad.values[50] = NAN;
  EXPECT_THAT(error_of([&] { h36m_motion_to_bvh(bad, 25.0); }), HasSubstr("not finite"));
  EXPECT_THAT(error_of([&] { h36m_motion_to_bvh(random_motion(2, 1), 0.0); }), HasSubstr("rate"));
}

}  // namespace
}  // namespace mm
