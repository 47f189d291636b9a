// Where the trained default model lives, so that the tool (and the server)
// start on a real manifold with no extra step.
//
// Thread safety: safe to call concurrently.
#pragma once

#include <string>

namespace mm {

// $MM_MODEL_DIR when set and non-empty; otherwise the model shipped in the
// source tree this binary was built from (models/h36m-dkgm-h100).
std::string default_model_dir();

}  // namespace mm
