#include "server/core/take_session.h"

#include <algorithm>
#include <cstring>

#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"

namespace mm::service {

const char* take_call_name(TakeOperation operation) {
  switch (operation) {
    case TakeOperation::kEncode: return "encode_take";
    case TakeOperation::kReconstruct: return "reconstruct_take";
    case TakeOperation::kDenoise: return "denoise_take";
  }
  return "take";
}

TakeFile take_from_text(const std::string& data, const std::string& source, const std::string& field, int columns,
                        double frame_rate, bool allow_nan) {
  TakeFile take;
  take.frame_rate = frame_rate;
  try {
    take.frames = parse_motion_text_buffer(data.data(), data.size(), source, columns, allow_nan);
  } catch (const InputError& e) {
    throw ApiError(ErrorCode::kInvalidArgument, field, e.what());
  }
  return take;
}

TakeFile take_from_bvh(const std::string& data, const std::string& source, const std::string& field,
                       const Skeleton& skeleton, AnimationFormat format) {
  TakeFile take;
  try {
    const BvhFile file = parse_animation_file(data, format, source, bvh_layout_of(skeleton).millimetres_per_unit);
    take.frame_rate = bvh_frame_rate(file);
    take.frames = skeleton_motion_from_bvh_at_file_rate(skeleton, file, source);
  } catch (const InputError& e) {
    throw ApiError(ErrorCode::kInvalidArgument, field, e.what());
  }
  return take;
}

TakeChunkReader take_file_reader(std::shared_ptr<const TakeFile> take, int64_t chunk_frames) {
  auto next = std::make_shared<int64_t>(0);
  return [take = std::move(take), next, chunk_frames](TakeChunk& chunk) {
    const int64_t total = take->frames.frame_count();
    if (*next >= total) return false;
    const int64_t count = std::min(chunk_frames, total - *next);
    const int columns = take->frames.columns;
    const float* first = take->frames.values.data() + *next * columns;
    chunk.frames = count;
    chunk.values.assign(first, first + count * columns);
    *next += count;
    return true;
  };
}

}  // namespace mm::service
