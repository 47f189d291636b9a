#include "server/rest/join_route.h"

#include <httplib.h>

#include <cstdlib>
#include <optional>

#include "server/rest/body_for_model.h"
#include "server/rest/bvh_translation.h"
#include "server/rest/http_errors.h"
#include "server/rest/json_translation.h"

namespace mm::service::rest {
namespace {

constexpr const char* kJsonType = "application/json";

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

// A file part of a multipart body: its bytes and the format its name's
// extension, else its Content-Type, else its first bytes say.
struct ClipPart {
  const std::string* content = nullptr;
  AnimationFormat format = AnimationFormat::kBvh;
};

ClipPart clip_part(const httplib::MultipartFormData& part) {
  ClipPart clip{&part.content};
  if (animation_format_of_path(part.filename, &clip.format)) return clip;
  if (names_animation(part.content_type, &clip.format)) return clip;
  if (sniff_animation_format(part.content.data(), part.content.size(), &clip.format)) return clip;
  throw invalid(part.name, "part \"" + part.name + "\" (" + (part.filename.empty() ? "no file name" : part.filename) +
                               ", Content-Type " + (part.content_type.empty() ? "none" : part.content_type) +
                               ") is not " + animation_formats_listed() + " of the model's skeleton");
}

double seconds_field(const httplib::MultipartFormData& part) {
  char* end = nullptr;
  const double value = std::strtod(part.content.c_str(), &end);
  if (part.content.empty() || end != part.content.c_str() + part.content.size()) {
    throw invalid(part.name, "expected a number of seconds, found \"" + part.content.substr(0, 40) + "\"");
  }
  return value;
}

// The request of a multipart body but its clips, which are read for the
// model that answers (answer_join), and the parts that hold them.
JoinClipsRequest multipart_request(const httplib::MultipartFormDataItems& parts, std::optional<ClipPart>& a,
                                   std::optional<ClipPart>& b) {
  JoinClipsRequest request;
  for (const auto& part : parts) {
    if (part.name == "a") {
      a = clip_part(part);
    } else if (part.name == "b") {
      b = clip_part(part);
    } else if (part.name == "model") {
      request.model = part.content;
    } else if (part.name == "transition_seconds") {
      request.transition_seconds = seconds_field(part);
    } else if (part.name == "method") {
      request.method = part.content;
    } else if (part.name == "decoder") {
      request.decoder = part.content;
    } else {
      throw invalid(part.name, "unknown part \"" + part.name +
                                   "\", expected a, b, model, transition_seconds, method or decoder");
    }
  }
  if (!a) throw invalid("a", "expected a file part \"a\" (the first clip)");
  if (!b) throw invalid("b", "expected a file part \"b\" (the second clip)");
  return request;
}

}  // namespace

void answer_join(Core& core, const CallContext& context, const httplib::Request& request,
                 const std::string& body, const httplib::MultipartFormDataItems& parts, httplib::Response& response) {
  AnimationFormat reply_format;
  const bool file_reply = names_animation(request.get_header_value("Accept"), &reply_format);
  if (file_reply && reply_format == AnimationFormat::kFbx) {
    // FBX is read, never written (format/fbx_animation.h says why).
    response.status = 406;
    return response.set_content(
        error_body(ApiError(ErrorCode::kInvalidArgument, "",
                            "Accept: application/octet-stream (FBX) cannot be answered: the joined motion is "
                            "written as application/x-bvh, model/gltf-binary, model/gltf+json or application/json")),
        kJsonType);
  }
  // Files (parts a and b, the joined motion as a file) are of the skeleton
  // of the model that answers: it is chosen first (Core::choose_model), the
  // parts read for it, the clips joined on it, the reply written for it.
  JoinClipsRequest join;
  ChosenModel chosen;
  if (request.is_multipart_form_data()) {
    std::optional<ClipPart> a, b;
    join = multipart_request(parts, a, b);
    chosen = core.choose_model(context, "join_clips", join.model);
    read_body_for_model(core, chosen, [&](const ModelShape& shape) {
      join.a = clip_from_animation_body(*a->content, shape, a->format, "a");
      join.b = clip_from_animation_body(*b->content, shape, b->format, "b");
    });
  } else {
    const std::string content_type = request.get_header_value("Content-Type");
    AnimationFormat body_format;
    if (names_animation(content_type, &body_format)) {
      throw invalid("", "POST /v1/join takes two clips: send them as JSON, or as the files \"a\" and \"b\" of a "
                        "multipart/form-data body (curl -F a=@first.bvh -F b=@second.bvh), not one " +
                            content_type + " body");
    }
    join = join_clips_request_from_json(body);
    if (file_reply) chosen = core.choose_model(context, "join_clips", join.model);
  }
  const JoinClipsReply reply = core.join_clips(context, join, chosen);
  if (!file_reply) {
    response.status = 200;
    return response.set_content(join_clips_reply_to_json(reply), kJsonType);
  }
  MotionsReply motions;
  motions.answered_by = reply.answered_by;
  motions.motions.push_back(reply.motion);
  response.status = 200;
  response.set_header("X-Transition-First-Frame", std::to_string(reply.transition_first_frame));
  response.set_header("X-Transition-Last-Frame", std::to_string(reply.transition_last_frame));
  response.set_content(motions_reply_to_bvh(motions, chosen.shape(), reply_format),
                       animation_format_media_type(reply_format));
}

}  // namespace mm::service::rest
