// The motion files of the data root (--data-root) as clips a client can
// pick on the server instead of uploading one: the list of them, one window
// of one as a wire motion at the model's 25 Hz, and a new file written there
// (a user's own mocap, to train on). ManifoldCore's ListClips, ReadClip and
// UploadClip are these.
//
// The window is taken as the server takes an uploaded motion, so that
// encoding it gives the code of the upload: an H3.6M text file (50 Hz) keeps
// every second row from `start`, as Encode downsamples a 50 Hz motion; a BVH
// is resampled to 25 Hz by nearest frames from `start` (format/skeleton_bvh.h),
// in the model's skeleton when the file's hierarchy is the model's and in
// its own otherwise (layout "expmap-<columns>").
//
// Only what lies under the root is read: `..` and links are resolved before
// the check (data_root_path.h), links to folders are not followed when
// listing, and links that leave the root are neither listed nor read.
//
// Torch-free. Thread safety: pure functions (they read the file system).
// Refusals are ApiError naming the field ("path", "start"), the value and
// what was expected.
#pragma once

#include <string>

#include "core/api_types.h"
#include "core/motion_conversion.h"

namespace mm::service {

// The formats ListClips and ReadClip name.
constexpr const char* kH36mTextFormat = "h36m-text";
constexpr const char* kBvhFormat = "bvh";

// Every *.txt and *.bvh file (extension in any case) under `data_root`,
// recursively, hidden files and folders (a name starting with '.') left out,
// sorted by path; the first `max_clips` of them, `truncated` when there were
// more. FAILED_PRECONDITION when `data_root` is empty (the server was started
// without --data-root) or not a folder.
ListClipsReply list_data_root_clips(const std::string& data_root, int max_clips);

// The window of `request.path` from frame `request.start` (the file's own
// frames) of shape.frames frames at 25 Hz. FAILED_PRECONDITION without a
// data root; INVALID_ARGUMENT "path" for an empty path, one outside the
// root, a folder, another extension, a file too short for one window, or a
// malformed one (the parser's message, naming the file by its relative
// path); NOT_FOUND "path" when nothing is there; INVALID_ARGUMENT "start"
// when it is negative or past the last full window (naming the largest
// valid start); RESOURCE_EXHAUSTED "path" for a file over 256 MiB.
ReadClipReply read_data_root_clip(const std::string& data_root, const ReadClipRequest& request,
                                  const ModelShape& shape);

// Largest file UploadClip takes (the frontends' message limits may be lower).
constexpr size_t kMaxUploadedClipBytes = size_t{256} << 20;
// Longest folder or file name of an uploaded path, in bytes.
constexpr size_t kMaxUploadedNameBytes = 128;

// Writes `request.content` as the new file `request.path` under the data
// root, creating its folders, and returns it as ListClips lists it. The
// content is checked first as its extension says (H3.6M text of 99 values a
// line; BVH of any hierarchy) and written whole under a hidden name, then
// linked into place, so a reader or a crash never sees part of it and an
// existing file is never replaced. FAILED_PRECONDITION without a data root;
// INVALID_ARGUMENT "path" for a path that is empty, absolute, has an empty
// component, one starting with '.' or one over kMaxUploadedNameBytes, has
// another extension, or leads out of the root; FAILED_PRECONDITION "path" when a file is already there;
// INVALID_ARGUMENT "content" for empty or malformed content (the parser's
// message); RESOURCE_EXHAUSTED "content" over kMaxUploadedClipBytes;
// INTERNAL when the file system refuses the write.
ClipFile write_data_root_clip(const std::string& data_root, const UploadClipRequest& request);

}  // namespace mm::service
