// The core's configuration (server_config.cpp fills it from flags, the
// environment and a configuration file): the model store, the token, the
// data root, the limits of a request, the executor's batching. Plain
// values in a torch-free header of their own, so that a part that only
// reads them (the executor, the server's flags) does not include the core.
#pragma once

#include <cstddef>
#include <string>

#include "server/core/data_root_clips.h"
#include "server/core/model_precisions.h"
#include "server/core/take_session.h"
#include "server/core/watch_streams.h"

namespace mm::service {

// Request limits: each refusal names the limit (RESOURCE_EXHAUSTED, 413).
struct Limits {
  int max_motions = 64;       // motions of one Encode or Denoise; codes of one Decode
  int max_sample_count = 64;  // Sample's count
  int max_steps = 64;         // Interpolate's steps
  int max_denoise_iterations = 32;
};

// The inference executor's dynamic batching (as Triton's dynamic batcher):
// requests of the same model, operation and decoder are run as one batch of
// at most max_batch clips. A batch waits up to max_queue_delay_us for more
// requests only while more clients have been calling lately than it holds (a
// lone client never waits). The default is long because on two cores the 31
// clients a batch of 32 has just answered take 20 to 60 ms to call again
// (their replies are serialised on the same cores); with 20 ms, 32 clients
// got 44 clips/s in alternating half batches, with 60 ms 64 clips/s in full
// ones (docs/PERFORMANCE.md). More than max_queue_length waiting requests are
// refused (429).
struct BatchingConfig {
  int max_batch = 32;
  int max_queue_delay_us = 60000;
  int max_queue_length = 256;
  int threads = 0;  // LibTorch intra-op threads of the executor; 0: chosen by timing (engine/thread_count_tuner.h)
};

struct CoreConfig {
  std::string model_store;    // folder of model folders
  std::string default_model;  // name in the store; empty: the first of h36m-dkgm-h100 or the only model
  // Calls that change state (and clip reads) need this token; empty: they
  // are taken only from loopback.
  std::string auth_token;
  bool public_clips = false;  // ListClips and ReadClip open to every caller
  // The folder of motion files ListClips and ReadClip serve (--data-root, the
  // folder training datasets lie under); empty: none.
  std::string data_root;
  int max_listed_clips = 10000;  // ListClips lists the first ones by path and says it truncated
  DataRootQuota data_root_quota;  // what uploads may add to the data root
  // The training jobs' store (--job-store): a PostgreSQL one makes the
  // replicas sharing it one deployment, with one active model and one quota
  // of the data root (engine/shared_deployment.h); "" or SQLite: one server.
  std::string job_store;
  int max_loaded_models = 4;  // models kept in memory, the active one included
  ModelPrecisions precisions;  // the number format of each model's inference weights
  Limits limits;
  BatchingConfig batching;
  WatchStreamLimits watch_streams;  // open job watch streams, both protocols together
  TakeLimits takes;  // take operations (core/take_session.h)
  size_t max_take_bytes = size_t{512} << 20;  // a take read whole: a REST body, a data-root file
  // A motion answered whole in one reply (ReadClip's whole read): at most
  // what one gRPC message may carry (--max-message-bytes sets both).
  size_t max_reply_bytes = size_t{64} << 20;
};

}  // namespace mm::service
