// Atomic file replacement: readers of `path` see either the old file or the
// complete new one, never a half-written file, even if the writer crashes.
//
// Training runs and the server write files that other processes read while
// they run (prepared data sets, exported motions); writing a temporary file in
// the same directory and renaming it over the target gives that guarantee on
// POSIX file systems, because rename() within one file system is atomic.
#pragma once

#include <string>

namespace mm {

// Writes `bytes` to `path` through a temporary file in the same directory
// ("<path>.tmp.<pid>.<n>") followed by rename(). Returns nothing on success.
// Throws InputError when the temporary file cannot be created (bad directory,
// no permission) and std::runtime_error when writing or renaming fails (disk
// full, I/O error); the temporary file is removed on every error path.
// Thread safety: safe to call concurrently for different paths; concurrent
// writers of the same path each succeed and the last rename wins.
void write_file_atomically(const std::string& path, const std::string& bytes);

// Reads the whole file into a string. Throws InputError naming the path and
// the system's reason when it cannot be opened or read. Thread safe.
std::string read_whole_file(const std::string& path);

}  // namespace mm
