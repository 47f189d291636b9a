// Checking and converting the wire's motions and codes for a model: a Motion
// becomes the library's MotionFrames at the model's 25 Hz (a 50 Hz motion
// keeps every second frame, as the tool and `prepare` downsample), and every
// refusal is an ApiError naming the field as the wire spells it, the value,
// and what was expected. Torch-free: it runs on the frontends' threads.
// Thread safety: pure functions.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "format/skeleton.h"
#include "server/api/api_types.h"

namespace mm::service {

// What a model takes: its clip length at 25 Hz, columns, layout name, code
// size, and the skeleton its motions are of (for BVH in and out).
struct ModelShape {
  int frames = 150;
  int columns = 99;
  int latent = 64;
  std::string layout = kH36mLayout;
  Skeleton skeleton = Skeleton::h36m();
};

// The layout name of a model with `columns` input columns: "h36m-expmap-99"
// for H3.6M's 99, "expmap-<columns>" otherwise.
std::string layout_name(int columns);

// `motion` at 25 Hz, exactly shape.frames frames, for field `field`
// ("motions[2]", "from.motion"). Refused: a layout other than the model's,
// a column count other than the model's, a rate other than 25 or 50, a frame
// count other than shape.frames (25 Hz) or 2 x shape.frames (50 Hz), a
// values array of another length than frames x columns, and values that are
// not finite or out of the text format's bounds (format/motion_text.h).
// A motion whose root is "generated" (a reply's, in world layout) is
// brought back to the root changes the model reads (format/root_path.h).
MotionFrames to_model_frames(const Motion& motion, const ModelShape& shape, const std::string& field);

// The same for a clip of any length (JoinClips' clips): `motion` at 25 Hz
// with at least `min_frames` and at most `max_frames` frames at 25 Hz.
// Fewer is INVALID_ARGUMENT "<field>.frames" saying `min_why` (what the
// minimum is for); more is RESOURCE_EXHAUSTED (413) "<field>.frames" naming
// `max_option`, checked before a value is read.
MotionFrames clip_to_model_frames(const Motion& motion, const ModelShape& shape, const std::string& field,
                                  int64_t min_frames, const std::string& min_why, int64_t max_frames,
                                  const std::string& max_option);

// A motion of the model's output (25 Hz, its layout) as the core's API
// answers it (api_types.h's Motion, which the frontends translate), with
// `root` saying where its root path comes from ("generated", "input",
// "none") and the planted feet of every frame (format/foot_contacts.h).
Motion to_api_motion(const MotionFrames& frames, const ModelShape& shape, const std::string& root);

// Checks a code for field `field`: shape.latent finite values within +-1e3
// (a code from the prior has |values| below 6).
void check_code(const Code& code, const ModelShape& shape, const std::string& field);

}  // namespace mm::service
