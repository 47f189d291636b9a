#include "server/engine/take_operations.h"

#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

#include "format/animation_file.h"
#include "format/input_error.h"
#include "format/motion_resampling.h"
#include "server/api/data_root_path.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// The field the library's error names (InputError::field), or `fallback`
// for an error that names none; the field once, beside the message, which
// the frontends and the client print after it.
ApiError from_input_error(const InputError& error, const std::string& fallback) {
  return invalid(error.field().empty() ? fallback : error.field(), error.detail());
}

void check_rate(double rate, const std::string& field) {
  try {
    check_take_rate(rate, field);
  } catch (const InputError& e) {
    throw from_input_error(e, field);
  }
}

TakeBlend blend_of(const std::string& name) {
  if (name.empty()) return TakeBlend::kCrossfade;
  try {
    return parse_take_blend(name);
  } catch (const InputError& e) {
    throw from_input_error(e, "blend");
  }
}

double window_seconds(const ModelShape& shape) { return shape.frames / kTakeModelRate; }

// The library's callbacks, forwarding to the wire's sink; start frames at
// the take's own rate.
TakeSink library_sink(const TakeReplySink& sink, double take_rate) {
  TakeSink out;
  out.on_window = [&sink, take_rate](const TakeWindowCode& window) {
    if (!sink.on_window) return;
    TakeWindow wire;
    wire.start_seconds = window.start_seconds;
    wire.start_frame = std::llround(window.start_seconds * take_rate);
    wire.code = window.code;
    sink.on_window(wire);
  };
  out.on_frames = [&sink](const MotionFrames& frames, const std::vector<float>& error_mm) {
    if (sink.on_frames && frames.frame_count() > 0) {
      sink.on_frames(frames.values.data(), error_mm.empty() ? nullptr : error_mm.data(), frames.frame_count());
    }
  };
  return out;
}

}  // namespace

TakeSummary run_take_on_model(const LoadedModel& model, DecoderKind decoder, TakeOperation operation,
                              const TakeRequest& request, const TakeChunkReader& read, const TakeReplySink& sink,
                              const TorchRunner& run, const TakeBounds& bounds) {
  const ModelShape& shape = model.shape;
  check_rate(request.frame_rate, "frame_rate");
  if (request.columns != 0 && request.columns != shape.columns) {
    throw invalid("columns", "expected the " + std::to_string(shape.columns) + " columns of model \"" + model.name +
                                 "\" (" + shape.layout + "), found " + std::to_string(request.columns));
  }
  if (!request.layout.empty() && request.layout != shape.layout) {
    throw invalid("layout", "expected \"" + shape.layout + "\" (model \"" + model.name + "\") or empty, found \"" +
                                request.layout + "\"");
  }
  TakeOptions options;
  options.operation = operation;
  options.frame_rate = request.frame_rate;
  options.hop_seconds = request.hop_seconds == 0 ? kDefaultHopSeconds : request.hop_seconds;
  options.blend = blend_of(request.blend);
  options.at_model_rate = request.at_model_rate;
  options.decoder = decoder;
  options.max_seconds = bounds.limits.max_seconds;
  options.max_seconds_name = "--max-take-seconds";
  if (operation == TakeOperation::kDenoise) {
    const int iterations = request.iterations == 0 ? 4 : request.iterations;
    if (iterations < 1) throw invalid("iterations", "expected at least 1 (0: four), found " + std::to_string(iterations));
    if (iterations > bounds.max_denoise_iterations) {
      throw ApiError(ErrorCode::kResourceExhausted, "iterations",
                     "at most " + std::to_string(bounds.max_denoise_iterations) +
                         " allowed (the server's max_denoise_iterations), found " + std::to_string(iterations),
                     true);
    }
    if (request.zeros_are_missing && request.means_are_missing) {
      throw invalid("means_are_missing", "expected either zeros_are_missing or means_are_missing, found both");
    }
    options.denoise.zeros_are_missing = request.zeros_are_missing;
    options.denoise.means_are_missing = request.means_are_missing;
    options.denoise.iterations = iterations;
    options.denoise.keep_observed = request.keep_observed;
    options.gap_fit.max_windows = bounds.limits.max_gap_fits;
    if (!request.gap_fill.empty()) {
      try {
        options.gap_fill.method = parse_gap_method(request.gap_fill, "gap_fill");
      } catch (const InputError& e) {
        throw from_input_error(e, "gap_fill");
      }
    }
  }
  if (!request.gap_fill.empty() && !(operation == TakeOperation::kDenoise && request.keep_observed)) {
    throw invalid("gap_fill", "applies to DenoiseTake with keep_observed only, found \"" + request.gap_fill +
                                  "\"; expected it empty");
  }
  if (!request.root.empty() && request.root != "input" && request.root != "generated") {
    throw invalid("root", "expected \"input\" or \"generated\" (or empty: input), found \"" + request.root + "\"");
  }
  if (request.root == "generated") {
    if (!model.model.has_trajectory()) {
      throw invalid("root", "\"generated\" needs a model with a trajectory network, which model \"" + model.name +
                                "\" lacks; expected \"input\"");
    }
    if (operation != TakeOperation::kEncode) options.root = TakeRoot::kGenerated;
  }

  const TakeSink forward = library_sink(sink, request.frame_rate);
  std::unique_ptr<TakeProcessor> processor;
  try {
    processor = std::make_unique<TakeProcessor>(model.model, options, forward, run);
  } catch (const InputError& e) {
    throw from_input_error(e, "take");
  }
  const int columns = processor->columns();
  if (sink.on_start) {
    TakeReplyStart start;
    start.answered_by = {model.name, model.version};
    start.frame_rate = request.at_model_rate ? kTakeModelRate : request.frame_rate;
    start.columns = columns;
    start.layout = shape.layout;
    sink.on_start(start);
  }

  // The longest take in frames: its duration is (frames - 1) / rate.
  const double max_frames = bounds.limits.max_seconds * request.frame_rate + 1 + 1e-6;
  int64_t frames = 0;
  TakeChunk chunk;
  while (read(chunk)) {
    if (chunk.frames < 1) {
      throw invalid("chunk.frames", "expected at least 1 frame a chunk, found " + std::to_string(chunk.frames));
    }
    const uint64_t expected = static_cast<uint64_t>(chunk.frames) * static_cast<uint64_t>(columns);
    if (chunk.values.size() != expected) {
      throw invalid("chunk.values", "expected frames x columns = " + std::to_string(chunk.frames) + " x " +
                                        std::to_string(columns) + " = " + std::to_string(expected) +
                                        " values (the header's columns), found " +
                                        std::to_string(chunk.values.size()));
    }
    if (bounds.limits.max_seconds > 0 && static_cast<double>(frames + chunk.frames) > max_frames) {
      throw ApiError(ErrorCode::kResourceExhausted, "take",
                     "the take passes " + number(bounds.limits.max_seconds) + " s (the server's --max-take-seconds) at frame " +
                         std::to_string(static_cast<int64_t>(max_frames)) + " of " + number(request.frame_rate) +
                         " Hz; expected a shorter take",
                     true);
    }
    try {
      processor->push(chunk.values.data(), chunk.frames);
    } catch (const InputError& e) {
      throw invalid("chunk.values", e.what());  // names the take frame and column
    }
    frames += chunk.frames;
  }
  if (frames == 0) {
    throw invalid("take", "the take ended before its first frame; expected a take of at least " +
                              number(window_seconds(shape)) + " s");
  }
  try {
    return processor->finish();
  } catch (const InputError& e) {
    throw from_input_error(e, "take");
  }
}

TakeSummary decode_track_on_model(const LoadedModel& model, DecoderKind decoder,
                                  const DecodeTrackRequest& request, const TakeReplySink& sink,
                                  const TorchRunner& run, const TakeBounds& bounds) {
  const ModelShape& shape = model.shape;
  const double rate = request.frame_rate == 0 ? kTakeModelRate : request.frame_rate;
  check_rate(rate, "frame_rate");
  if (request.frames < 0) throw invalid("frames", "expected 0 (the track's length) or more, found " + std::to_string(request.frames));
  if (request.windows.empty()) throw invalid("windows", "expected at least one window, found none");
  const double max_seconds = bounds.limits.max_seconds;
  std::vector<TakeWindowCode> track;
  track.reserve(request.windows.size());
  for (size_t i = 0; i < request.windows.size(); ++i) {
    const TakeWindow& window = request.windows[i];
    const std::string field = "windows[" + std::to_string(i) + "]";
    if (!std::isfinite(window.start_seconds)) {
      throw invalid(field + ".start_seconds", "expected a finite number of seconds, found " + number(window.start_seconds));
    }
    check_code(window.code, shape, field + ".code");
    TakeWindowCode code;
    code.start_seconds = window.start_seconds;
    code.start_frame = std::llround(window.start_seconds * kTakeModelRate);
    code.code = window.code;
    track.push_back(std::move(code));
  }
  const double track_seconds = track.back().start_seconds + window_seconds(shape);
  if (max_seconds > 0 && track_seconds > max_seconds + 1e-9) {
    throw ApiError(ErrorCode::kResourceExhausted, "windows",
                   "the track lasts " + number(track_seconds) + " s, more than " + number(max_seconds) +
                       " s (the server's --max-take-seconds)",
                   true);
  }
  if (max_seconds > 0 && request.frames > 0 && (request.frames - 1) / rate > max_seconds + 1e-9) {
    throw ApiError(ErrorCode::kResourceExhausted, "frames",
                   std::to_string(request.frames) + " frames at " + number(rate) + " Hz last more than " +
                       number(max_seconds) + " s (the server's --max-take-seconds)",
                   true);
  }
  CodeTrackDecoding options;
  options.frame_rate = rate;
  options.frames = request.frames == 0 ? -1 : request.frames;
  options.blend = blend_of(request.blend);
  options.decoder = decoder;
  options.max_seconds = max_seconds;
  options.max_seconds_name = "--max-take-seconds";
  if (sink.on_start) {
    TakeReplyStart start;
    start.answered_by = {model.name, model.version};
    start.frame_rate = rate;
    start.columns = shape.columns;
    start.layout = shape.layout;
    sink.on_start(start);
  }
  try {
    return decode_code_track(model.model, track, options, library_sink(sink, rate), run);
  } catch (const InputError& e) {
    throw from_input_error(e, "windows");
  }
}

TakeFile read_take_file(const std::string& data_root, const std::string& path, const ModelShape& shape,
                        double text_rate, bool allow_nan, size_t max_bytes) {
  if (data_root.empty()) {
    throw ApiError(ErrorCode::kFailedPrecondition, "path",
                   "this server has no data root (--data-root), so a take cannot name a file there");
  }
  const fs::path root = canonical_data_root(data_root);
  if (path.empty()) throw invalid("path", "path is empty, expected a .txt or .bvh file under the data root");
  const auto resolved = resolve_under_data_root(root, path, "path");
  if (!resolved) {
    throw invalid("path", "path \"" + path + "\" lies outside the data root, expected a file under it");
  }
  std::error_code error;
  if (!fs::exists(*resolved, error)) {
    throw ApiError(ErrorCode::kNotFound, "path", "path \"" + path + "\" names no file under the data root");
  }
  if (!fs::is_regular_file(*resolved, error)) throw invalid("path", "path \"" + path + "\" is not a file");
  std::string extension = resolved->extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  AnimationFormat animation_format;
  const bool animation = animation_format_of_path(resolved->string(), &animation_format);
  if (extension != ".txt" && !animation) {
    throw invalid("path", "path \"" + path + "\" is neither motion text (.txt) nor " + animation_formats_listed());
  }
  const uintmax_t size = fs::file_size(*resolved, error);
  if (error) throw invalid("path", "path \"" + path + "\" cannot be read: " + error.message());
  if (size > max_bytes) {
    throw ApiError(ErrorCode::kResourceExhausted, "path",
                   "path \"" + path + "\" is " + std::to_string(size) + " bytes, more than the " +
                       std::to_string(max_bytes) + " of a take (--max-take-bytes)",
                   true);
  }
  std::ifstream in(*resolved, std::ios::binary);
  std::string data(static_cast<size_t>(size), '\0');
  if (!in.read(data.data(), static_cast<std::streamsize>(size))) {
    throw invalid("path", "path \"" + path + "\" cannot be read");
  }
  const std::string source = resolved->lexically_relative(root).generic_string();
  if (animation) return take_from_bvh(data, source, "path", shape.skeleton, animation_format);
  const double rate = text_rate == 0 ? kH36mFrameRate : text_rate;
  check_rate(rate, "frame_rate");
  return take_from_text(data, source, "path", shape.columns, rate, allow_nan);
}

}  // namespace mm::service
