// The reference the web tests compare with: the model library's forward
// kinematics (model/forward_kinematics.h, the server's) of a 25 Hz H3.6M
// text motion, and optionally the library's BVH export of it
// (format/h36m_bvh.h, the code behind the tool's and the REST API's BVH).
//
//   web_fk_reference MOTION.txt                      -> JSON [frames][32][3] positions, mm, on stdout
//   web_fk_reference MOTION.txt --bvh OUT.bvh [--rotation-order XYZ] [--position-channels]
//
// Exit status 2 with the reason on stderr for bad input.
#include <ATen/ATen.h>

#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "format/h36m_bvh.h"
#include "format/motion_text.h"
#include "forward_kinematics.h"

namespace {

void print_positions(const mm::MotionFrames& motion) {
  const mm::ForwardKinematics fk(mm::Skeleton::h36m());
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
    if (argc < 2) throw std::runtime_error("usage: web_fk_reference MOTION.txt [--bvh OUT.bvh [--rotation-order XYZ] [--position-channels]]");
    const mm::MotionFrames motion = mm::read_motion_text(argv[1]);
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
      } else {
        throw std::runtime_error("unknown argument " + arg);
      }
    }
    if (bvh_path.empty()) {
      print_positions(motion);
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
