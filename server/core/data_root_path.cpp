#include "core/data_root_path.h"

#include <algorithm>

#include "core/api_types.h"

namespace mm::service {

namespace fs = std::filesystem;

bool is_under(const fs::path& path, const fs::path& root) {
  const auto mismatch = std::mismatch(root.begin(), root.end(), path.begin(), path.end());
  return mismatch.first == root.end();
}

fs::path canonical_data_root(const std::string& data_root) {
  std::error_code error;
  const fs::path root = fs::weakly_canonical(fs::path(data_root), error);
  if (error) throw ApiError(ErrorCode::kInternal, "", "data root " + data_root + ": " + error.message());
  return root;
}

std::optional<fs::path> resolve_under_data_root(const fs::path& root, const std::string& name) {
  std::error_code error;
  const fs::path path = fs::weakly_canonical(root / name, error);
  if (error || !is_under(path, root)) return std::nullopt;
  return path;
}

}  // namespace mm::service
