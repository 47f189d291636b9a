// The motion files of the data root (--data-root) as clips a client can
// pick on the server instead of uploading one: the list of them, one window
// of one as a wire motion at the model's 25 Hz, and a new file written there
// (a user's own mocap, to train on) or removed again. ManifoldCore's
// ListClips, ReadClip, UploadClip and DeleteClip are these.
//
// The window is taken as the server takes an uploaded motion, so that
// encoding it gives the code of the upload: an H3.6M text file (50 Hz) keeps
// every second row from `start`, as Encode downsamples a 50 Hz motion; a BVH
// is resampled to 25 Hz by nearest frames from `start` (format/skeleton_bvh.h),
// in the model's skeleton when the file's hierarchy is the model's and in
// its own otherwise (layout "expmap-<columns>").
//
// Only what lies under the root is read: `..` and links are resolved before
// the check (api/data_root_path.h), links to folders are not followed when
// listing, and links that leave the root are neither listed nor read.
//
// Torch-free. Thread safety: pure functions (they read the file system).
// Refusals are ApiError naming the field ("path", "start"), the value and
// what was expected.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/motion_conversion.h"

namespace mm::service {

class UploadReservations;  // jobs/upload_reservations.h

// The formats ListClips and ReadClip name.
constexpr const char* kH36mTextFormat = "h36m-text";
constexpr const char* kBvhFormat = "bvh";
// glTF (*.glb, *.gltf) and FBX (*.fbx) files, read as BVH is
// (format/animation_file.h).
constexpr const char* kGltfFormat = "gltf";
constexpr const char* kFbxFormat = "fbx";

// Every *.txt, *.bvh, *.glb, *.gltf and *.fbx file (extension in any case) under `data_root`,
// recursively, hidden files and folders (a name starting with '.') left out,
// sorted by path; the first `max_clips` of them, `truncated` when there were
// more. FAILED_PRECONDITION when `data_root` is empty (the server was started
// without --data-root) or not a folder.
ListClipsReply list_data_root_clips(const std::string& data_root, int max_clips);

// The window of `request.path` from frame `request.start` (the file's own
// frames) of shape.frames frames at 25 Hz. FAILED_PRECONDITION without a
// data root; INVALID_ARGUMENT "path" for an empty path, one holding a
// control character, one outside the root, a folder, another extension, a
// file too short for one window, one longer than the longest take (a BVH's
// frames x frame time, a text's rows: checked before its values are read),
// or a malformed one (the parser's message, naming the file by its relative
// path); NOT_FOUND "path" when nothing is there; INVALID_ARGUMENT "start"
// when it is negative or past the last full window (naming the largest
// valid start); RESOURCE_EXHAUSTED "path" for a file over 256 MiB. Only the
// window's frames are resampled, or its rows parsed. A text's value marked
// missing (`nan` in a joint column, as DenoiseTake reads it) comes back NaN,
// here and in a whole read: the page shows such a take and fills its gaps
// (Encode refuses the NaN, naming the value).
//
// With request.whole, every frame of the file at its own rate instead, as a
// take names the file (TakeRequest.path): H3.6M text's rows at 50 Hz in
// their 99 columns; a BVH, glTF or FBX of the model's skeleton at its rate
// in the model's layout (another skeleton is refused naming "path", as
// skeleton_motion_from_bvh_at_file_rate refuses a take's). INVALID_ARGUMENT
// "start" unless start is 0; INVALID_ARGUMENT "path" for a file whose last
// frame lies past limits.max_seconds (--max-take-seconds; 0: no limit, as
// for takes), or whose values (4 bytes each) exceed limits.max_bytes (what
// one gRPC message may carry, --max-message-bytes: a reply it could not
// send is refused before it is made, and REST's JSON stays within about
// three times that), naming its length and the limit, checked on the rows
// counted (text) or the frames declared (animation files) before any value
// is read or resampled.
struct WholeReadLimits {
  double max_seconds = 0;  // 0: no limit
  size_t max_bytes = 0;    // 0: no limit
};
ReadClipReply read_data_root_clip(const std::string& data_root, const ReadClipRequest& request,
                                  const ModelShape& shape, const WholeReadLimits& whole_limits);

// What the data root may hold, checked before an upload writes anything
// (--max-upload-bytes, --max-data-root-bytes, --max-data-root-files).
struct DataRootQuota {
  int64_t max_upload_bytes = int64_t{64} << 20;       // one uploaded file
  int64_t max_root_bytes = int64_t{16} << 30;         // every file under the root together
  int64_t max_root_files = 100000;                    // files under the root, hidden ones included
  // Replicas sharing the data root and a PostgreSQL job store: every upload
  // in flight on any of them, reserved in that database before a byte is
  // written, counts against the quota too. Null (one server, the SQLite
  // default): this server's uploads are checked one at a time.
  std::shared_ptr<UploadReservations> shared;
};

// What the data root holds: its regular files (links not followed, hidden
// files included, the upload marks of write_data_root_clip and its
// temporary files left out: an upload in flight is counted by its own size,
// and one a crash left behind is swept at the next start), counted on every
// upload (one stat a file under the root).
struct DataRootUse {
  int64_t bytes = 0;
  int64_t files = 0;
};
DataRootUse data_root_use(const std::string& data_root);
// Longest folder or file name of an uploaded path, in bytes.
constexpr size_t kMaxUploadedNameBytes = 128;

// Writes `request.content` as the new file `request.path` under the data
// root, creating its folders, and returns it as ListClips lists it. The
// content is checked first as its extension says (H3.6M text of 99 values a
// line; BVH of any hierarchy) and against the quota, and written whole under
// a hidden name, then linked into place, so a reader or a crash never sees
// part of it and an existing file is never replaced. The file is then
// marked as uploaded (an empty file of the same relative path under the
// root's hidden folder ".uploads"), which is what lets DeleteClip remove it.
// Uploads of one server are written one at a time, so that two cannot both
// pass the quota; with quota.shared, those of every replica are checked one
// at a time against the root and what the others have reserved. FAILED_PRECONDITION without a data root;
// INVALID_ARGUMENT "path" for a path that is empty, absolute, has an empty
// component, one starting with '.' or one over kMaxUploadedNameBytes,
// holds a control character, has another extension, or leads out of the
// root; FAILED_PRECONDITION "path" when a file is already there;
// INVALID_ARGUMENT "content" for empty or malformed content (the parser's
// message); RESOURCE_EXHAUSTED "content" (413) over quota.max_upload_bytes,
// or when the root would then hold more than quota.max_root_bytes or
// quota.max_root_files (naming the quota, the current use and the option);
// INTERNAL when the file system refuses the write.
ClipFile write_data_root_clip(const std::string& data_root, const UploadClipRequest& request,
                              const DataRootQuota& quota);

// Whether `filename` is a temporary file of write_data_root_clip
// (".<name>.upload.<pid>.<n>" for a clip <name>, or that followed by
// ".tmp.<pid>.<n>", as earlier versions wrote them): the only names
// sweep_upload_leftovers removes.
bool is_upload_temporary_name(const std::string& filename);

// What a sweep removed: paths relative to the root, and their bytes.
struct SweptUploads {
  std::vector<std::string> paths;
  int64_t bytes = 0;
};
// At start: removes the temporary files of uploads whose writer died (a
// crash mid-write), which nothing else would ever remove. A writer holds an
// exclusive flock(2) on its temporary file from its creation until it is
// linked into place and unlinked, and the kernel drops the lock when the
// process dies, so a file whose lock can be taken has no live writer; one
// still locked belongs to an upload in flight (another replica sharing the
// data root) and is left alone. The earlier versions' names, whose writers
// took no lock, are removed only when unchanged for 10 minutes (their
// writes took seconds). Only names is_upload_temporary_name
// accepts, only regular files (never a link), under the root's non-hidden
// folders (where uploads are written). Logs what it removed. Never throws
// (what it cannot read it leaves).
SweptUploads sweep_upload_leftovers(const std::string& data_root);

// Removes a file that UploadClip wrote under the data root (found by the
// one containment check, api/data_root_path.h) and returns it as it was listed.
// Only uploaded files may be removed: the rest of the root is the operator's
// (a dataset such as H3.6M, put there by hand), which a caller holding the
// token may read and train on but not destroy. FAILED_PRECONDITION without
// a data root; INVALID_ARGUMENT "path" for an empty path, one outside the
// root, a folder or another extension; NOT_FOUND "path" when nothing is
// there; FAILED_PRECONDITION "path" for a file that was not uploaded.
ClipFile delete_data_root_clip(const std::string& data_root, const std::string& path);

}  // namespace mm::service
