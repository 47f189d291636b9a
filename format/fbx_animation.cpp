#include "format/fbx_animation.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>
#include <map>
#include <memory>

#include "format/input_error.h"
#include "format/node_animation_in_child.h"

namespace mm {
namespace {

// The file's length unit in metres: FBX's UnitScaleFactor is centimetres per
// unit (1 for cm, 100 for m); cm without one.
double metres_per_file_unit(const aiScene& scene) {
  if (scene.mMetaData) {
    double d;
    float f;
    if (scene.mMetaData->Get("UnitScaleFactor", d) && d > 0 && std::isfinite(d)) return d / 100.0;
    if (scene.mMetaData->Get("UnitScaleFactor", f) && f > 0 && std::isfinite(f)) return f / 100.0;
  }
  return 0.01;
}

void decompose(const aiMatrix4x4& m, double metres, Vec3* translation, Quaternion* rotation, Vec3* scale) {
  aiVector3D s, t;
  aiQuaternion q;
  m.Decompose(s, q, t);
  *translation = {t.x * metres, t.y * metres, t.z * metres};
  *rotation = {q.x, q.y, q.z, q.w};
  *scale = {s.x, s.y, s.z};
}

// The import itself, in the child process.
NodeAnimation import_fbx(const char* data, size_t size, const std::string& source_name, const BvhFrameLimit& limit) {
  Assimp::Importer importer;
  // Pivots and pre-rotations folded into each node's transform and keys:
  // no "$AssimpFbx$" helper nodes between joints.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
  const aiScene* scene = importer.ReadFileFromMemory(data, size, 0, "fbx");
  if (!scene || !scene->mRootNode) {
    throw InputError(source_name + ": not an FBX file assimp reads: " + importer.GetErrorString());
  }
  if (scene->mNumAnimations == 0) throw InputError(source_name + ": the FBX file holds no animation");
  const aiAnimation& clip = *scene->mAnimations[0];
  const double ticks_per_second = clip.mTicksPerSecond > 0 ? clip.mTicksPerSecond : kBvhImportRate;
  const double metres = metres_per_file_unit(*scene);

  // The skeleton's root: the nearest common ancestor of the animated nodes.
  std::map<std::string, const aiNodeAnim*> channel_of;
  const aiNode* root = nullptr;
  for (unsigned c = 0; c < clip.mNumChannels; ++c) {
    const aiNodeAnim* channel = clip.mChannels[c];
    const aiNode* node = scene->mRootNode->FindNode(channel->mNodeName);
    if (!node) continue;
    channel_of[channel->mNodeName.C_Str()] = channel;
    if (!root) {
      root = node;
      continue;
    }
    auto depth = [](const aiNode* n) {
      int d = 0;
      for (; n->mParent; n = n->mParent) ++d;
      return d;
    };
    const aiNode* a = root;
    const aiNode* b = node;
    while (depth(a) > depth(b)) a = a->mParent;
    while (depth(b) > depth(a)) b = b->mParent;
    while (a != b) {
      a = a->mParent;
      b = b->mParent;
    }
    root = a;
  }
  if (!root) throw InputError(source_name + ": the FBX animation moves no node of the scene");

  NodeAnimation animation;
  // Above the root: its ancestors' transforms (file units).
  aiMatrix4x4 above;
  for (const aiNode* p = root->mParent; p; p = p->mParent) above = p->mTransformation * above;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) animation.above_root_linear[i][j] = above[i][j];
    animation.above_root_translation[i] = above[i][3] * metres;
  }
  std::vector<const aiNode*> order;
  std::vector<std::pair<const aiNode*, int>> stack{{root, -1}};
  std::vector<NodeKeyframes> keys;
  while (!stack.empty()) {
    const auto [node, parent] = stack.back();
    stack.pop_back();
    if (node != root && node->mNumMeshes > 0) continue;
    if (order.size() >= static_cast<size_t>(kMaxBvhJoints)) {
      throw InputError(source_name + ": a skeleton of more than " + std::to_string(kMaxBvhJoints) + " nodes");
    }
    AnimationNode out;
    out.name = node->mName.C_Str();
    out.parent = parent;
    decompose(node->mTransformation, metres, &out.rest_translation, &out.rest_rotation, &out.rest_scale);
    const int index = static_cast<int>(order.size());
    order.push_back(node);
    animation.nodes.push_back(out);
    NodeKeyframes node_keys;
    const auto found = channel_of.find(out.name);
    if (found != channel_of.end()) {
      const aiNodeAnim& channel = *found->second;
      for (unsigned k = 0; k < channel.mNumPositionKeys; ++k) {
        const aiVectorKey& key = channel.mPositionKeys[k];
        node_keys.translation_times.push_back(key.mTime / ticks_per_second);
        node_keys.translations.push_back({key.mValue.x * metres, key.mValue.y * metres, key.mValue.z * metres});
      }
      for (unsigned k = 0; k < channel.mNumRotationKeys; ++k) {
        const aiQuatKey& key = channel.mRotationKeys[k];
        node_keys.rotation_times.push_back(key.mTime / ticks_per_second);
        node_keys.rotations.push_back({key.mValue.x, key.mValue.y, key.mValue.z, key.mValue.w});
      }
    }
    keys.push_back(std::move(node_keys));
    for (unsigned c = node->mNumChildren; c-- > 0;) stack.push_back({node->mChildren[c], index});
  }
  sample_node_keyframes(animation, keys, size, source_name, limit);
  drop_still_roots(animation);
  return animation;
}

}  // namespace

NodeAnimation read_fbx_animation(const char* data, size_t size, const std::string& source_name,
                                 const BvhFrameLimit& limit) {
  // assimp may abort on a malformed file (node_animation_in_child.h).
  return read_in_child_process(source_name + ": the FBX reader", child_memory_budget(size), [&] {
    return import_fbx(data, size, source_name, limit);
  });
}

}  // namespace mm
