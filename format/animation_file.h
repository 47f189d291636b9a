// Animation files of a skeleton in the formats animation tools exchange:
// BVH (bvh_file.h), glTF 2.0 (.glb binary, .gltf JSON; gltf_animation.h)
// and FBX (fbx_animation.h, read only), all read into and written from the one
// in-memory form the library works on, BvhFile.
//
// A BVH's lengths are in the rig's own unit (mm for H3.6M, cm for the CMU
// files: the skeleton's BvhLayout::millimetres_per_unit); glTF's are metres
// and FBX's centimetres, so the writers and readers take that unit. No axis
// is changed: a BVH's axes are the file's axes, as Blender's BVH importer
// and its glTF and FBX exporters together leave them.
//
// Reentrant. Errors are InputError naming `source_name`.
#pragma once

#include <cstddef>
#include <string>

#include "format/bvh_file.h"

namespace mm {

enum class AnimationFormat { kBvh, kGlb, kGltf, kFbx };

// "BVH", "glTF binary (.glb)", "glTF JSON (.gltf)", "FBX".
const char* animation_format_name(AnimationFormat format);
// ".bvh", ".glb", ".gltf", ".fbx".
const char* animation_format_extension(AnimationFormat format);
// The media type of replies: application/x-bvh, model/gltf-binary,
// model/gltf+json, application/octet-stream (FBX has no registered type).
const char* animation_format_media_type(AnimationFormat format);
// The format a path's extension names (any case); false for another.
bool animation_format_of_path(const std::string& path, AnimationFormat* format);
// The format a media type names (parameters and case ignored): the four
// above; false for another. application/octet-stream is FBX (a caller that
// takes bytes of it checks them with sniff_animation_format).
bool animation_format_of_media_type(const std::string& media_type, AnimationFormat* format);
// The format of a file's first bytes: "glTF" (.glb), "Kaydara FBX Binary"
// (FBX), '{' after blanks (.gltf), "HIERARCHY" after blanks (BVH); false when
// none.
bool sniff_animation_format(const char* data, size_t size, AnimationFormat* format);
// The format of an input named `name` whose bytes begin with `data`: its
// extension's, else (standard input, a name without one of the four) its
// first bytes'; false for neither (motion text, say).
bool animation_format_of_input(const std::string& name, const char* data, size_t size, AnimationFormat* format);
// "a .bvh, .glb, .gltf or .fbx file": how refusals list the formats.
const char* animation_formats_listed();

// Parses a file of `format` as BVH in units of `millimetres_per_unit` mm
// (the rig's unit; ignored for BVH, which is in its own): for glTF and FBX
// a value <= 0 takes the unit our writer recorded in a glTF file, else mm.
// `limit` as parse_bvh_text's, checked before frames are sampled.
BvhFile parse_animation_file(const char* data, size_t size, AnimationFormat format, const std::string& source_name,
                             double millimetres_per_unit, const BvhFrameLimit& limit = {});
BvhFile parse_animation_file(const std::string& bytes, AnimationFormat format, const std::string& source_name,
                             double millimetres_per_unit, const BvhFrameLimit& limit = {});

// The file's bytes in `format` (write_bvh_text for BVH), lengths of `file`
// in units of `millimetres_per_unit` mm. Throws InputError as
// write_bvh_text does, and for FBX, which is read but never written
// (fbx_animation.h says why).
std::string write_animation_file(const BvhFile& file, AnimationFormat format, double millimetres_per_unit);

}  // namespace mm
