#include "format/gltf_animation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

// tinygltf compiled here, as its upstream means it (header-only): the shared
// library Debian also ships disagrees with the header on the loader's
// layout (its SetFsCallbacks overwrote our loader's error string). No image
// decoder: a motion has no images (keep_image keeps their bytes undecoded).
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "format/input_error.h"

namespace mm {
namespace {

constexpr const char* kGenerator = "Motion Manifold";

// ---- writing ----

// Appends `bytes` to the buffer as a buffer view (4-byte aligned, as
// accessors of floats require) and returns the view's index.
int add_view(tinygltf::Model& model, const void* bytes, size_t size) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  while (data.size() % 4) data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  const auto* begin = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), begin, begin + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size()) - 1;
}

int add_float_accessor(tinygltf::Model& model, const std::vector<float>& values, int type, int components,
                       bool with_bounds) {
  tinygltf::Accessor accessor;
  accessor.bufferView = add_view(model, values.data(), values.size() * sizeof(float));
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.type = type;
  accessor.count = values.size() / components;
  if (with_bounds) {
    // Required for animation inputs; readers size their clips from them.
    accessor.minValues.assign(components, std::numeric_limits<double>::infinity());
    accessor.maxValues.assign(components, -std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < values.size(); ++i) {
      const size_t c = i % components;
      accessor.minValues[c] = std::min<double>(accessor.minValues[c], values[i]);
      accessor.maxValues[c] = std::max<double>(accessor.maxValues[c], values[i]);
    }
  }
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size()) - 1;
}

tinygltf::Value bvh_extras(const AnimationNode& node) {
  tinygltf::Value::Array channels;
  for (BvhChannel channel : node.bvh_channels) channels.emplace_back(std::string(bvh_channel_name(channel)));
  tinygltf::Value::Object bvh;
  bvh["channels"] = tinygltf::Value(channels);
  bvh["end_site"] = tinygltf::Value(node.end_site);
  tinygltf::Value::Object extras;
  extras["bvh"] = tinygltf::Value(bvh);
  return tinygltf::Value(extras);
}

// ---- reading ----

// Refuses every file access: a request's glTF names no file of the server.
// Every file "exists", so that tinygltf asks to read it and the refusal
// below says why.
bool file_refused_on_read(const std::string&, void*) { return true; }
std::string unexpanded(const std::string& path, void*) { return path; }
bool no_file_read(std::vector<unsigned char>*, std::string* err, const std::string& path, void*) {
  if (err) *err += "it refers to the external file \"" + path + "\"; only embedded buffers (.glb, or data: URIs) are read\n";
  return false;
}
bool no_file_written(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing files is not allowed\n";
  return false;
}
// Images are kept undecoded: only the skeleton and its animation matter.
bool keep_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// Values of an accessor as doubles, `components` per element, with every
// byte checked to lie within its view and buffer (tinygltf does not check).
std::vector<double> accessor_values(const tinygltf::Model& model, int index, int components, const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    throw InputError(what + ": accessor " + std::to_string(index) + " does not exist");
  }
  const tinygltf::Accessor& accessor = model.accessors[index];
  const std::string name = what + " (accessor " + std::to_string(index) + ")";
  if (accessor.sparse.isSparse) throw InputError(name + ": sparse accessors are not read");
  const int type_components = tinygltf::GetNumComponentsInType(accessor.type);
  if (type_components != components) {
    throw InputError(name + ": " + std::to_string(type_components) + " components an element, expected " +
                     std::to_string(components));
  }
  if (accessor.bufferView < 0 || static_cast<size_t>(accessor.bufferView) >= model.bufferViews.size()) {
    throw InputError(name + ": no buffer view");
  }
  const tinygltf::BufferView& view = model.bufferViews[accessor.bufferView];
  if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size()) {
    throw InputError(name + ": its view's buffer " + std::to_string(view.buffer) + " does not exist");
  }
  const std::vector<unsigned char>& buffer = model.buffers[view.buffer].data;
  const int component_size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  if (component_size <= 0) throw InputError(name + ": unknown component type " + std::to_string(accessor.componentType));
  const size_t element = static_cast<size_t>(component_size) * components;
  const size_t stride = view.byteStride ? view.byteStride : element;
  const size_t count = accessor.count;
  if (count == 0) return {};
  // Checked in this order, none of the sums can overflow: each term is
  // first bounded by the buffer's size.
  const size_t buffer_size = buffer.size();
  if (view.byteOffset > buffer_size || view.byteLength > buffer_size - view.byteOffset ||
      accessor.byteOffset > view.byteLength || stride < element || count - 1 > view.byteLength / stride ||
      accessor.byteOffset + (count - 1) * stride + element > view.byteLength) {
    throw InputError(name + ": " + std::to_string(count) + " elements do not fit in its buffer view of " +
                     std::to_string(view.byteLength) + " bytes");
  }
  const unsigned char* base = buffer.data() + view.byteOffset + accessor.byteOffset;
  std::vector<double> values(count * components);
  for (size_t i = 0; i < count; ++i) {
    const unsigned char* at = base + i * stride;
    for (int c = 0; c < components; ++c) {
      const unsigned char* p = at + c * component_size;
      double v;
      switch (accessor.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: { float x; std::memcpy(&x, p, 4); v = x; break; }
        // Normalised integers: rotations may be stored so (glTF 2.0, 3.11).
        case TINYGLTF_COMPONENT_TYPE_BYTE: { int8_t x; std::memcpy(&x, p, 1); v = std::max(x / 127.0, -1.0); break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: { uint8_t x; std::memcpy(&x, p, 1); v = x / 255.0; break; }
        case TINYGLTF_COMPONENT_TYPE_SHORT: { int16_t x; std::memcpy(&x, p, 2); v = std::max(x / 32767.0, -1.0); break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { uint16_t x; std::memcpy(&x, p, 2); v = x / 65535.0; break; }
        default:
          throw InputError(name + ": component type " + std::to_string(accessor.componentType) +
                           ", expected floats (or normalised integers)");
      }
      values[i * components + c] = v;
    }
  }
  return values;
}

// A node's rest transform from its TRS or its matrix (column-major, as glTF
// stores it), the matrix split into translation, rotation and scale.
void rest_transform(const tinygltf::Node& node, Vec3* translation, Quaternion* rotation, Vec3* scale) {
  *translation = {0, 0, 0};
  *rotation = {0, 0, 0, 1};
  *scale = {1, 1, 1};
  if (node.matrix.size() == 16) {
    const auto& m = node.matrix;
    *translation = {m[12], m[13], m[14]};
    Mat3 r{};
    for (int j = 0; j < 3; ++j) {
      const double n = std::sqrt(m[4 * j] * m[4 * j] + m[4 * j + 1] * m[4 * j + 1] + m[4 * j + 2] * m[4 * j + 2]);
      (*scale)[j] = n;
      for (int i = 0; i < 3; ++i) r[i][j] = n > 0 ? m[4 * j + i] / n : (i == j);
    }
    *rotation = matrix_to_quaternion(r);
    return;
  }
  if (node.translation.size() == 3) *translation = {node.translation[0], node.translation[1], node.translation[2]};
  if (node.rotation.size() == 4) *rotation = {node.rotation[0], node.rotation[1], node.rotation[2], node.rotation[3]};
  if (node.scale.size() == 3) *scale = {node.scale[0], node.scale[1], node.scale[2]};
}

// Reads a node's extras.bvh layout written by write_gltf_animation; false
// when it has none.
bool read_bvh_extras(const tinygltf::Value& extras, AnimationNode& node, const std::string& what) {
  if (!extras.IsObject() || !extras.Has("bvh")) return false;
  const tinygltf::Value& bvh = extras.Get("bvh");
  // An empty list of channels comes back from tinygltf's writer as null.
  const tinygltf::Value& channels = bvh.Get("channels");
  if (!bvh.IsObject() || !(channels.IsArray() || channels.Type() == tinygltf::NULL_TYPE) || !bvh.Get("end_site").IsBool()) {
    throw InputError(what + ": extras.bvh, expected {\"channels\": [names], \"end_site\": true or false}");
  }
  if (channels.ArrayLen() > 6) throw InputError(what + ": extras.bvh.channels holds more than 6 channels");
  for (size_t c = 0; channels.IsArray() && c < channels.ArrayLen(); ++c) {
    const tinygltf::Value& name = channels.Get(static_cast<int>(c));
    BvhChannel channel;
    if (!name.IsString() || !parse_bvh_channel(name.Get<std::string>(), &channel) ||
        std::count(node.bvh_channels.begin(), node.bvh_channels.end(), channel)) {
      throw InputError(what + ": extras.bvh.channels[" + std::to_string(c) +
                       "] is not a BVH channel (Xposition ... Zrotation, none twice)");
    }
    node.bvh_channels.push_back(channel);
  }
  node.end_site = bvh.Get("end_site").Get<bool>();
  if (node.end_site && !node.bvh_channels.empty()) throw InputError(what + ": an End Site with channels");
  node.has_bvh_layout = true;
  return true;
}

}  // namespace

std::string write_gltf_animation(const NodeAnimation& animation, bool binary) {
  const size_t nodes = animation.nodes.size();
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = kGenerator;
  if (animation.millimetres_per_unit > 0) {
    tinygltf::Value::Object extras;
    extras["bvh_millimetres_per_unit"] = tinygltf::Value(animation.millimetres_per_unit);
    model.asset.extras = tinygltf::Value(extras);
  }
  model.buffers.resize(1);

  // Rest world positions (identity rest rotations, as node_animation_from_bvh
  // makes them) for the inverse bind matrices.
  std::vector<Vec3> rest_world(nodes);
  for (size_t j = 0; j < nodes; ++j) {
    const AnimationNode& in = animation.nodes[j];
    tinygltf::Node node;
    node.name = in.name;
    node.translation = {in.rest_translation[0], in.rest_translation[1], in.rest_translation[2]};
    if (in.rest_rotation != Quaternion{0, 0, 0, 1}) {
      node.rotation = {in.rest_rotation[0], in.rest_rotation[1], in.rest_rotation[2], in.rest_rotation[3]};
    }
    if (in.has_bvh_layout) node.extras = bvh_extras(in);
    rest_world[j] = in.rest_translation;
    if (in.parent >= 0) {
      for (int k = 0; k < 3; ++k) rest_world[j][k] += rest_world[in.parent][k];
      model.nodes[in.parent].children.push_back(static_cast<int>(j));
    }
    model.nodes.push_back(node);
  }
  tinygltf::Scene scene;
  scene.name = "motion";
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  tinygltf::Skin skin;
  skin.name = "skeleton";
  skin.skeleton = 0;
  std::vector<float> inverse_bind;
  for (size_t j = 0; j < nodes; ++j) {
    skin.joints.push_back(static_cast<int>(j));
    const float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, static_cast<float>(-rest_world[j][0]),
                         static_cast<float>(-rest_world[j][1]), static_cast<float>(-rest_world[j][2]), 1};
    inverse_bind.insert(inverse_bind.end(), m, m + 16);
  }
  skin.inverseBindMatrices = add_float_accessor(model, inverse_bind, TINYGLTF_TYPE_MAT4, 16, false);
  model.skins.push_back(skin);

  tinygltf::Animation clip;
  clip.name = "motion";
  std::vector<float> times(static_cast<size_t>(animation.frames));
  for (int64_t f = 0; f < animation.frames; ++f) times[f] = static_cast<float>(f / animation.rate_hz);
  const int input = add_float_accessor(model, times, TINYGLTF_TYPE_SCALAR, 1, true);
  auto add_channel = [&](size_t node, const char* path, const std::vector<float>& values, int type, int components) {
    tinygltf::AnimationSampler sampler;
    sampler.input = input;
    sampler.output = add_float_accessor(model, values, type, components, false);
    sampler.interpolation = "LINEAR";
    clip.samplers.push_back(sampler);
    tinygltf::AnimationChannel channel;
    channel.sampler = static_cast<int>(clip.samplers.size()) - 1;
    channel.target_node = static_cast<int>(node);
    channel.target_path = path;
    clip.channels.push_back(channel);
  };
  for (size_t j = 0; j < nodes; ++j) {
    const AnimationNode& node = animation.nodes[j];
    if (node.animated_translation) {
      std::vector<float> values;
      values.reserve(static_cast<size_t>(animation.frames) * 3);
      for (int64_t f = 0; f < animation.frames; ++f) {
        for (double v : animation.translations[f * nodes + j]) values.push_back(static_cast<float>(v));
      }
      add_channel(j, "translation", values, TINYGLTF_TYPE_VEC3, 3);
    }
    if (node.animated_rotation) {
      std::vector<float> values;
      values.reserve(static_cast<size_t>(animation.frames) * 4);
      Quaternion previous{0, 0, 0, 1};
      for (int64_t f = 0; f < animation.frames; ++f) {
        Quaternion q = animation.rotations[f * nodes + j];
        // The sign nearest the previous key, so that interpolation between
        // keys takes the short way in every reader.
        if (q[0] * previous[0] + q[1] * previous[1] + q[2] * previous[2] + q[3] * previous[3] < 0) {
          for (double& v : q) v = -v;
        }
        previous = q;
        for (double v : q) values.push_back(static_cast<float>(v));
      }
      add_channel(j, "rotation", values, TINYGLTF_TYPE_VEC4, 4);
    }
  }
  model.animations.push_back(clip);

  tinygltf::TinyGLTF writer;
  std::ostringstream out;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false, binary)) {
    throw InputError("glTF export: tinygltf could not write the file");
  }
  return out.str();
}

NodeAnimation read_gltf_animation(const char* data, size_t size, const std::string& source_name,
                                  const BvhFrameLimit& limit) {
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{file_refused_on_read, unexpanded, no_file_read, no_file_written, nullptr};
  loader.SetFsCallbacks(fs);
  loader.SetImageLoader(keep_image, nullptr);
  tinygltf::Model model;
  std::string error, warning;
  const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  if (size > std::numeric_limits<unsigned int>::max()) throw InputError(source_name + ": larger than 4 GiB");
  const bool loaded =
      binary ? loader.LoadBinaryFromMemory(&model, &error, &warning, reinterpret_cast<const unsigned char*>(data),
                                           static_cast<unsigned int>(size), "")
             : loader.LoadASCIIFromString(&model, &error, &warning, data, static_cast<unsigned int>(size), "");
  if (!loaded) {
    while (!error.empty() && error.back() == '\n') error.pop_back();
    throw InputError(source_name + ": not a glTF 2.0 file" + (binary ? " (.glb)" : " (.gltf JSON)") + ": " +
                     (error.empty() ? "unreadable" : error));
  }
  if (model.animations.empty()) throw InputError(source_name + ": the glTF file holds no animation");

  // The node tree: one parent each, no cycles.
  const int count = static_cast<int>(model.nodes.size());
  std::vector<int> parent(count, -1);
  for (int n = 0; n < count; ++n) {
    for (int child : model.nodes[n].children) {
      if (child < 0 || child >= count || child == n || parent[child] != -1) {
        throw InputError(source_name + ": node " + std::to_string(n) + " lists child " + std::to_string(child) +
                         ", which does not exist or has another parent");
      }
      parent[child] = n;
    }
  }
  std::vector<int> depth(count, -1);
  for (int n = 0; n < count; ++n) {
    int d = 0;
    for (int p = parent[n]; p >= 0; p = parent[p]) {
      if (++d > count) throw InputError(source_name + ": the node tree has a cycle through node " + std::to_string(n));
    }
    depth[n] = d;
  }

  // The skeleton's root: the nearest common ancestor of the skin's joints or
  // of the animated nodes.
  const tinygltf::Animation& clip = model.animations[0];
  std::vector<int> members;
  if (!model.skins.empty()) {
    members = model.skins[0].joints;
  } else {
    for (const auto& channel : clip.channels) members.push_back(channel.target_node);
  }
  int root = -1;
  for (int n : members) {
    if (n < 0 || n >= count) throw InputError(source_name + ": a skin joint or channel target " + std::to_string(n) + " is not a node");
    if (root < 0) {
      root = n;
      continue;
    }
    int a = root, b = n;
    while (depth[a] > depth[b]) a = parent[a];
    while (depth[b] > depth[a]) b = parent[b];
    while (a != b) {
      a = parent[a];
      b = parent[b];
      if (a < 0 || b < 0) throw InputError(source_name + ": the skeleton's joints lie in separate node trees");
    }
    root = a;
  }
  if (root < 0) throw InputError(source_name + ": no skeleton (the animation has no channels)");

  NodeAnimation animation;
  if (model.asset.extras.IsObject() && model.asset.extras.Has("bvh_millimetres_per_unit")) {
    const tinygltf::Value& unit = model.asset.extras.Get("bvh_millimetres_per_unit");
    if (unit.IsNumber() && unit.GetNumberAsDouble() > 0 && std::isfinite(unit.GetNumberAsDouble())) {
      animation.millimetres_per_unit = unit.GetNumberAsDouble();
    }
  }
  // Above the root: the product of its ancestors' rest transforms.
  std::vector<int> chain;
  for (int p = parent[root]; p >= 0; p = parent[p]) chain.push_back(p);
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    Vec3 t, s;
    Quaternion q;
    rest_transform(model.nodes[*it], &t, &q, &s);
    const Vec3 moved = multiply(animation.above_root_linear, t);
    for (int k = 0; k < 3; ++k) animation.above_root_translation[k] += moved[k];
    Mat3 local = quaternion_to_matrix(q);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) local[i][j] *= s[j];
    }
    animation.above_root_linear = multiply(animation.above_root_linear, local);
  }
  // The skeleton in depth-first pre-order, meshes and cameras left out.
  std::vector<int> index_of(count, -1);
  std::vector<int> order;
  std::vector<int> stack{root};
  while (!stack.empty()) {
    const int n = stack.back();
    stack.pop_back();
    const tinygltf::Node& node = model.nodes[n];
    if (n != root && (node.mesh >= 0 || node.camera >= 0)) continue;
    if (order.size() >= static_cast<size_t>(kMaxBvhJoints)) {
      throw InputError(source_name + ": a skeleton of more than " + std::to_string(kMaxBvhJoints) + " nodes");
    }
    index_of[n] = static_cast<int>(order.size());
    order.push_back(n);
    for (auto child = node.children.rbegin(); child != node.children.rend(); ++child) stack.push_back(*child);
  }
  for (int n : order) {
    const tinygltf::Node& node = model.nodes[n];
    AnimationNode out;
    out.name = node.name;
    out.parent = n == root ? -1 : index_of[parent[n]];
    rest_transform(node, &out.rest_translation, &out.rest_rotation, &out.rest_scale);
    read_bvh_extras(node.extras, out, source_name + ": node \"" + node.name + "\"");
    animation.nodes.push_back(std::move(out));
  }

  std::vector<NodeKeyframes> keys(order.size());
  for (size_t c = 0; c < clip.channels.size(); ++c) {
    const tinygltf::AnimationChannel& channel = clip.channels[c];
    if (channel.target_node < 0 || channel.target_node >= count || index_of[channel.target_node] < 0) continue;
    const bool translation = channel.target_path == "translation";
    if (!translation && channel.target_path != "rotation") continue;  // scale, morph weights
    const std::string what = source_name + ": animation channel " + std::to_string(c);
    if (channel.sampler < 0 || static_cast<size_t>(channel.sampler) >= clip.samplers.size()) {
      throw InputError(what + ": sampler " + std::to_string(channel.sampler) + " does not exist");
    }
    const tinygltf::AnimationSampler& sampler = clip.samplers[channel.sampler];
    const int components = translation ? 3 : 4;
    const std::vector<double> times = accessor_values(model, sampler.input, 1, what + "'s times");
    std::vector<double> values = accessor_values(model, sampler.output, components, what + "'s values");
    const bool cubic = sampler.interpolation == "CUBICSPLINE";
    if (cubic) {
      // In-tangent, value, out-tangent per key: the values alone.
      if (values.size() != times.size() * 3 * components) {
        throw InputError(what + ": CUBICSPLINE wants 3 values a key, found " + std::to_string(values.size() / components) +
                         " for " + std::to_string(times.size()) + " keys");
      }
      std::vector<double> kept;
      for (size_t k = 0; k < times.size(); ++k) {
        kept.insert(kept.end(), values.begin() + (3 * k + 1) * components, values.begin() + (3 * k + 2) * components);
      }
      values.swap(kept);
    }
    NodeKeyframes& node_keys = keys[index_of[channel.target_node]];
    const bool step = sampler.interpolation == "STEP";
    if (translation) {
      node_keys.translation_times = times;
      node_keys.translation_step = step;
      node_keys.translations.clear();
      for (size_t k = 0; k + 2 < values.size(); k += 3) node_keys.translations.push_back({values[k], values[k + 1], values[k + 2]});
    } else {
      node_keys.rotation_times = times;
      node_keys.rotation_step = step;
      node_keys.rotations.clear();
      for (size_t k = 0; k + 3 < values.size(); k += 4) {
        node_keys.rotations.push_back({values[k], values[k + 1], values[k + 2], values[k + 3]});
      }
    }
  }
  sample_node_keyframes(animation, keys, size, source_name, limit);
  drop_still_roots(animation);
  return animation;
}

}  // namespace mm
