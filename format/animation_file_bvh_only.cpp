// parse_animation_file and write_animation_file in a build without the glTF
// and FBX libraries (scripts/build-cuda.sh's tool): BVH only, the other
// formats refused saying so.
#include "format/animation_file.h"
#include "format/input_error.h"

namespace mm {
namespace {

[[noreturn]] void refuse(AnimationFormat format, const std::string& source_name) {
  throw InputError(source_name + ": " + animation_format_name(format) +
                   " is not read or written by this build (built without libassimp-dev and libtinygltf-dev); "
                   "use BVH");
}

}  // namespace

BvhFile parse_animation_file(const char* data, size_t size, AnimationFormat format, const std::string& source_name,
                             double, const BvhFrameLimit& limit) {
  if (format != AnimationFormat::kBvh) refuse(format, source_name);
  return parse_bvh_text(data, size, source_name, limit);
}

std::string write_animation_file(const BvhFile& file, AnimationFormat format, double) {
  if (format != AnimationFormat::kBvh) refuse(format, "export");
  return write_bvh_text(file);
}

}  // namespace mm
