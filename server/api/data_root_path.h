// Paths a client names under the server's data root (--data-root): training
// datasets and clip files. A client names them relative to the root (or
// absolute); `..` and symbolic links are resolved before the check, so that
// neither a `..` nor a link leads a request out of the folder the operator
// chose to expose; control characters (a NUL above all) are refused first.
//
// Torch-free. Thread safety: pure functions (they read the file system).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace mm::service {

// Whether `path` lies under `root` (or is it), compared component by
// component so that /data/root2 is not taken for a child of /data/root.
// Both must be normalised alike (canonical_data_root, resolve_under_data_root).
bool is_under(const std::filesystem::path& path, const std::filesystem::path& root);

// The data root with links and `..` resolved. Throws ApiError INTERNAL naming
// it when the file system cannot resolve it.
std::filesystem::path canonical_data_root(const std::string& data_root);

// The position (0-based byte) of the first control character (0x00 to
// 0x1F or 0x7F) in `name`; std::nullopt when it has none. A NUL would cut
// the path where the C library reads it (so "walking_1.txt\0.bvh" would be
// checked as a .bvh and opened as the .txt), and no motion file's name holds
// a line break or an escape sequence.
std::optional<size_t> first_control_character(const std::string& name);

// `name` (relative to `root`, or absolute) with `..` and symbolic links
// resolved; std::nullopt when the result lies outside `root` (a
// canonical_data_root) or cannot be resolved. The result need not exist.
// Every path a client names goes through here. Throws ApiError
// INVALID_ARGUMENT naming `field`, the character and its byte position when
// `name` holds a control character (first_control_character).
std::optional<std::filesystem::path> resolve_under_data_root(const std::filesystem::path& root,
                                                             const std::string& name, const std::string& field);

}  // namespace mm::service
