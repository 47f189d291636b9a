// Formats, their names and types; the readers and writers are in
// animation_file_io.cpp (or animation_file_bvh_only.cpp in a build without
// glTF and FBX libraries).
#include "format/animation_file.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>

#include "format/input_error.h"

namespace mm {
namespace {

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

size_t first_non_blank(const char* data, size_t size) {
  size_t at = 0;
  // A UTF-8 byte-order mark, as BVH text may start with one.
  if (size >= 3 && std::memcmp(data, "\xEF\xBB\xBF", 3) == 0) at = 3;
  while (at < size && std::isspace(static_cast<unsigned char>(data[at]))) ++at;
  return at;
}

}  // namespace

const char* animation_format_name(AnimationFormat format) {
  switch (format) {
    case AnimationFormat::kBvh: return "BVH";
    case AnimationFormat::kGlb: return "glTF binary (.glb)";
    case AnimationFormat::kGltf: return "glTF JSON (.gltf)";
    case AnimationFormat::kFbx: return "FBX";
  }
  return "?";
}

const char* animation_format_extension(AnimationFormat format) {
  switch (format) {
    case AnimationFormat::kBvh: return ".bvh";
    case AnimationFormat::kGlb: return ".glb";
    case AnimationFormat::kGltf: return ".gltf";
    case AnimationFormat::kFbx: return ".fbx";
  }
  return "";
}

const char* animation_format_media_type(AnimationFormat format) {
  switch (format) {
    case AnimationFormat::kBvh: return "application/x-bvh";
    case AnimationFormat::kGlb: return "model/gltf-binary";
    case AnimationFormat::kGltf: return "model/gltf+json";
    case AnimationFormat::kFbx: return "application/octet-stream";
  }
  return "";
}

const char* animation_formats_listed() { return "a .bvh, .glb, .gltf or .fbx file"; }

bool animation_format_of_path(const std::string& path, AnimationFormat* format) {
  const std::string extension = lower(std::filesystem::path(path).extension().string());
  for (AnimationFormat f : {AnimationFormat::kBvh, AnimationFormat::kGlb, AnimationFormat::kGltf, AnimationFormat::kFbx}) {
    if (extension == animation_format_extension(f)) {
      *format = f;
      return true;
    }
  }
  return false;
}

bool animation_format_of_media_type(const std::string& media_type, AnimationFormat* format) {
  std::string type = lower(media_type.substr(0, media_type.find(';')));
  type.erase(std::remove_if(type.begin(), type.end(), [](unsigned char c) { return std::isspace(c); }), type.end());
  for (AnimationFormat f : {AnimationFormat::kBvh, AnimationFormat::kGlb, AnimationFormat::kGltf, AnimationFormat::kFbx}) {
    if (type == animation_format_media_type(f)) {
      *format = f;
      return true;
    }
  }
  return false;
}

bool sniff_animation_format(const char* data, size_t size, AnimationFormat* format) {
  static const char kFbxMagic[] = "Kaydara FBX Binary";
  if (size >= 4 && std::memcmp(data, "glTF", 4) == 0) {
    *format = AnimationFormat::kGlb;
    return true;
  }
  if (size >= sizeof(kFbxMagic) - 1 && std::memcmp(data, kFbxMagic, sizeof(kFbxMagic) - 1) == 0) {
    *format = AnimationFormat::kFbx;
    return true;
  }
  const size_t at = first_non_blank(data, size);
  if (at < size && data[at] == '{') {
    *format = AnimationFormat::kGltf;
    return true;
  }
  if (size - at >= 9 && std::memcmp(data + at, "HIERARCHY", 9) == 0) {
    *format = AnimationFormat::kBvh;
    return true;
  }
  return false;
}

bool animation_format_of_input(const std::string& name, const char* data, size_t size, AnimationFormat* format) {
  return animation_format_of_path(name, format) || sniff_animation_format(data, size, format);
}

BvhFile parse_animation_file(const std::string& bytes, AnimationFormat format, const std::string& source_name,
                             double millimetres_per_unit, const BvhFrameLimit& limit) {
  return parse_animation_file(bytes.data(), bytes.size(), format, source_name, millimetres_per_unit, limit);
}

}  // namespace mm
