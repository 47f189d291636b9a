// The rig of the model a command's motions belong to: its skeleton, layout,
// columns and clip length, asked of the server (DescribeModel) the first time
// a motion file must be read or a BVH written, so that text and BVH of any
// model's skeleton travel (a manifold learnt from a user's own BVH files
// included), and a command that reads and writes no motion asks nothing.
// Not thread safe: one per command.
#pragma once

#include <map>
#include <string>

#include "client/cli/server_connection.h"
#include "format/skeleton.h"

namespace mm::client {

struct ModelRig {
  std::string model;   // its name in the server's store
  std::string layout;  // of its motions: "h36m-expmap-99", "expmap-<columns>"
  int columns = 0;     // values a frame
  int frames = 0;      // frames of one clip at 25 Hz
  Skeleton skeleton;   // with the BVH layout of a rig learnt from BVH files
};

class ModelRigs {
 public:
  explicit ModelRigs(ServerConnection& server) : server_(server) {}

  // The rig of `model` ("" for the active one), described once per name.
  // Throws ServerError as DescribeModel does, and for a description without
  // a usable skeleton.
  const ModelRig& of(const std::string& model);

  // The model a request should name: `model` itself, or for "" the name of
  // the active model when its rig was read, so that the server answers with
  // the model whose skeleton the request's motions were read in.
  std::string pinned(const std::string& model) const;

 private:
  ServerConnection& server_;
  std::map<std::string, ModelRig> described_;
};

}  // namespace mm::client
