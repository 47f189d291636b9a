#include "server/api/data_root_path.h"

#include <algorithm>
#include <cstdio>

#include "server/api/api_types.h"

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

std::optional<size_t> first_control_character(const std::string& name) {
  for (size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (c < 0x20 || c == 0x7F) return i;
  }
  return std::nullopt;
}

std::optional<fs::path> resolve_under_data_root(const fs::path& root, const std::string& name,
                                                const std::string& field) {
  if (const auto at = first_control_character(name)) {
    char code[8];
    std::snprintf(code, sizeof code, "0x%02X", static_cast<unsigned char>(name[*at]));
    throw ApiError(ErrorCode::kInvalidArgument, field,
                   field + " holds the control character " + code + " at byte " + std::to_string(*at) +
                       ", expected a path of printable characters");
  }
  std::error_code error;
  const fs::path path = fs::weakly_canonical(root / name, error);
  if (error || !is_under(path, root)) return std::nullopt;
  return path;
}

}  // namespace mm::service
