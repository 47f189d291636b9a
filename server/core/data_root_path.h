// Paths a client names under the server's data root (--data-root): training
// datasets and clip files. A client names them relative to the root (or
// absolute); `..` and symbolic links are resolved before the check, so that
// neither a `..` nor a link leads a request out of the folder the operator
// chose to expose.
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

// `name` (relative to `root`, or absolute) with `..` and symbolic links
// resolved; std::nullopt when the result lies outside `root` (a
// canonical_data_root) or cannot be resolved. The result need not exist.
std::optional<std::filesystem::path> resolve_under_data_root(const std::filesystem::path& root,
                                                             const std::string& name);

}  // namespace mm::service
