// The reference the web tests compare with: the model library's forward
// kinematics (model/forward_kinematics.h, the server's) of a 25 Hz text
// motion, or of a BVH file read as the server reads one
// (format/skeleton_bvh.h), of H3.6M's skeleton or of the skeleton in a JSON
// file (format/skeleton.h, as DescribeModel gives it); and optionally the
// library's BVH export of an H3.6M motion (format/h36m_bvh.h, the code behind
// the tool's and the REST API's BVH).
//
//   web_fk_reference MOTION.txt|MOTION.bvh [--skeleton S.json]  -> JSON [frames][joints][3] positions, mm, on stdout
//   web_fk_reference MOTION.txt --bvh OUT.bvh [--rotation-order XYZ] [--position-channels]
//
// Exit status 2 with the reason on stderr for bad input.
#include <ATen/ATen.h>

#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "model/forward_kinematics.h"

namespace {

void print_positions(const mm::MotionFrames& motion, const mm::Skeleton& skeleton) {
  const mm::ForwardKinematics fk(skeleton);
  const at::Tensor frames = at::from_blob(const_cast<float*>(motion.values.data()),
                                          {motion.frame_count(), motion.columns}, at::kFloat)
                                .to(at::kDouble);  // the reference in float64
  const at::Tensor positions = fk.positions(frames).contiguous();
  const double* p = positions.data_ptr<double>();
  const int64_t joints = positions.size(1);
  std::printf("[");
  for (int64_t f = 0; f < positions.size(0); ++f) {
    std::printf(f ? ",\n[" : "[");
    for (int64_t j = 0; j < joints; ++j) {
      const double* q = p + (f * joints + j) * 3;
      std::printf("%s[%.6f,%.6f,%.6f]", j ? "," : "", q[0], q[1], q[2]);
    }
    std::printf("]");
  }
  std::printf("]\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 2) {
      throw std::runtime_error("usage: web_fk_reference MOTION.txt|MOTION.bvh [--skeleton S.json] "
                               "[--bvh OUT.bvh [--rotation-order XYZ] [--position-channels]]");
    }
    const std::string motion_path = argv[1];
    mm::Skeleton skeleton = mm::Skeleton::h36m();
    std::string bvh_path;
    mm::H36mBvhExportOptions options;
    for (int i = 2; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--bvh" && i + 1 < argc) {
        bvh_path = argv[++i];
      } else if (arg == "--rotation-order" && i + 1 < argc) {
        if (!mm::EulerOrder::parse(argv[++i], &options.rotation_order))
          throw std::runtime_error(std::string("--rotation-order: not an order of X, Y, Z: ") + argv[i]);
      } else if (arg == "--position-channels") {
        options.position_channels_on_every_joint = true;
      } else if (arg == "--skeleton" && i + 1 < argc) {
        skeleton = mm::read_skeleton_file(argv[++i]);
      } else {
        throw std::runtime_error("unknown argument " + arg);
      }
    }
    const bool bvh_in = motion_path.size() > 4 && motion_path.substr(motion_path.size() - 4) == ".bvh";
    const mm::MotionFrames motion =
        bvh_in ? mm::skeleton_motion_from_bvh(skeleton, mm::read_bvh_file(motion_path), motion_path)
               : mm::read_motion_text(motion_path, mm::skeleton_motion_columns(skeleton));
    if (bvh_path.empty()) {
      print_positions(motion, skeleton);
      return 0;
    }
    std::ofstream out(bvh_path);
    out << mm::h36m_motion_to_bvh_text(motion, 25.0, options);
    if (!out) throw std::runtime_error("cannot write " + bvh_path);
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "web_fk_reference: %s\n", error.what());
    return 2;
  }
}
