#include "client/cli/model_rig.h"

#include "client/cli/server_error.h"
#include "format/input_error.h"
#include "format/skeleton_bvh.h"

namespace mm::client {

const ModelRig& ModelRigs::of(const std::string& model) {
  const auto known = described_.find(model);
  if (known != described_.end()) return known->second;
  const v1::ModelInfo info = server_.describe_model(model);
  ModelRig rig;
  rig.model = info.name();
  rig.layout = info.layout();
  rig.columns = info.columns();
  rig.frames = info.frames();
  // A server that predates the skeleton in DescribeModel serves H3.6M's
  // layout with H3.6M's skeleton; any other rig needs the description.
  const std::string& text = info.skeleton_json();
  if (text.empty() || text == "{}") {
    if (rig.layout != "h36m-expmap-99") {
      throw ServerError("UNIMPLEMENTED", "skeleton",
                        "the server does not describe the skeleton of model \"" + rig.model + "\" (layout " +
                            rig.layout + "); send its BVH over REST with Content-Type application/x-bvh");
    }
    rig.skeleton = Skeleton::h36m();
  } else {
    try {
      rig.skeleton = Skeleton::from_json_text(text, "the skeleton of model \"" + rig.model + "\"");
    } catch (const InputError& e) {
      throw ServerError("INTERNAL", "skeleton", e.what());
    }
    if (skeleton_motion_columns(rig.skeleton) != rig.columns) {
      throw ServerError("INTERNAL", "skeleton",
                        "the skeleton of model \"" + rig.model + "\" has " + std::to_string(rig.skeleton.joint_count()) +
                            " joints, which do not fit its " + std::to_string(rig.columns) + " columns");
    }
  }
  return described_.emplace(model, std::move(rig)).first->second;
}

std::string ModelRigs::pinned(const std::string& model) const {
  if (!model.empty()) return model;
  const auto active = described_.find("");
  return active == described_.end() ? "" : active->second.model;
}

}  // namespace mm::client
