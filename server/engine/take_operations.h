// The take operations on one loaded model, for ManifoldCore (which admits the
// call, picks the model and the decoder, and runs this inside its call
// wrapper). Checks every field of the request before any frame is read, runs
// the take through a TakeProcessor whose tensor work goes to `run` (the
// inference executor), and turns the library's InputError into ApiError
// naming the field.
//
// Internal to the core: includes LibTorch through model/, so only the core's
// .cpp files include it.
#pragma once

#include "model/take_processor.h"
#include "server/core/take_session.h"
#include "server/engine/model_store.h"

namespace mm::service {

struct TakeBounds {
  TakeLimits limits;
  int max_denoise_iterations = 32;
};

TakeSummary run_take_on_model(const LoadedModel& model, DecoderKind decoder, TakeOperation operation,
                              const TakeRequest& request, const TakeChunkReader& read, const TakeReplySink& sink,
                              const TorchRunner& run, const TakeBounds& bounds);

TakeSummary decode_track_on_model(const LoadedModel& model, DecoderKind decoder,
                                  const DecodeTrackRequest& request, const TakeReplySink& sink,
                                  const TorchRunner& run, const TakeBounds& bounds);

// The take in data-root file `path` (relative to the root, or absolute under
// it): motion text (.txt) at `text_rate` (0: 50 Hz) or BVH (.bvh) at its own
// rate. Refusals name "path" as ReadClip's do; RESOURCE_EXHAUSTED "path" for
// a file over `max_bytes`.
TakeFile read_take_file(const std::string& data_root, const std::string& path, const ModelShape& shape,
                        double text_rate, bool allow_nan, size_t max_bytes);

}  // namespace mm::service
