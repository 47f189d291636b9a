// One client's connection to the server and the one call it repeats, over
// gRPC (its own channel) or REST (its own keep-alive connection). The
// request is built once; each call() sends it and waits for the answer.
// Torch-free. Not thread safe: one driver per client thread.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace mm::client {

struct LoadCall {
  std::string operation = "decode";  // decode, encode or sample
  int batch = 1;                     // codes of a Decode, motions of an Encode, count of a Sample
  std::string model;                 // empty: the active model
  // Encode's motion: frames x 99 values at `frame_rate` Hz (h36m-expmap-99).
  std::vector<float> motion_values;
  int motion_frames = 0;
  double motion_frame_rate = 50;
};

class CallDriver {
 public:
  virtual ~CallDriver() = default;
  // Sends the call once; returns "OK" or the status (gRPC code name, or the
  // HTTP status and the error body's code).
  virtual std::string call() = 0;
};

// `seed` varies the codes between clients (N(0, 1) values).
std::unique_ptr<CallDriver> grpc_driver(const std::string& target, const LoadCall& call, unsigned seed);
std::unique_ptr<CallDriver> rest_driver(const std::string& host, int port, const LoadCall& call, unsigned seed);

}  // namespace mm::client
