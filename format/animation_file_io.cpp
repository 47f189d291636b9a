// parse_animation_file and write_animation_file with the glTF and FBX
// libraries (animation_file.h).
#include "format/animation_file.h"
#include "format/fbx_animation.h"
#include "format/gltf_animation.h"
#include "format/input_error.h"
#include "format/node_animation.h"

namespace mm {

BvhFile parse_animation_file(const char* data, size_t size, AnimationFormat format, const std::string& source_name,
                             double millimetres_per_unit, const BvhFrameLimit& limit) {
  if (format == AnimationFormat::kBvh) return parse_bvh_text(data, size, source_name, limit);
  NodeAnimation animation = format == AnimationFormat::kFbx ? read_fbx_animation(data, size, source_name, limit)
                                                            : read_gltf_animation(data, size, source_name, limit);
  double unit = millimetres_per_unit;
  if (!(unit > 0)) unit = animation.millimetres_per_unit > 0 ? animation.millimetres_per_unit : 1.0;
  return bvh_from_node_animation(animation, unit, source_name);
}

std::string write_animation_file(const BvhFile& file, AnimationFormat format, double millimetres_per_unit) {
  if (format == AnimationFormat::kBvh) return write_bvh_text(file);
  if (format == AnimationFormat::kFbx) {
    // See fbx_animation.h: the library's FBX writer makes unreadable files.
    throw InputError("FBX export is not available (the FBX library writes files that Blender cannot read); "
                     "write .glb, .gltf or .bvh");
  }
  if (file.joints.empty() || file.frame_count() < 1) {
    throw InputError(std::string(animation_format_name(format)) + " export: no joints or no frames");
  }
  const NodeAnimation animation = node_animation_from_bvh(file, millimetres_per_unit);
  return write_gltf_animation(animation, format == AnimationFormat::kGlb);
}

}  // namespace mm
