#include "format/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "format/input_error.h"

namespace mm {

void write_file_atomically(const std::string& path, const std::string& bytes) {
  // pid + per-process counter keeps concurrent writers (threads or processes)
  // from sharing a temporary file.
  static std::atomic<unsigned long> counter{0};
  const std::string temp = path + ".tmp." + std::to_string(::getpid()) + "." +
                           std::to_string(counter.fetch_add(1));
  std::FILE* file = std::fopen(temp.c_str(), "wb");
  if (file == nullptr) {
    throw InputError(path + ": cannot create temporary file " + temp + ": " +
                     std::strerror(errno));
  }
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  const int saved_errno = errno;
  // fclose flushes; its failure (e.g. ENOSPC on flush) also means a bad file.
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) {
    std::remove(temp.c_str());
    throw std::runtime_error(path + ": writing " + temp + " failed: " +
                             std::strerror(written ? errno : saved_errno));
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    const int rename_errno = errno;
    std::remove(temp.c_str());
    throw std::runtime_error(path + ": renaming " + temp + " into place failed: " +
                             std::strerror(rename_errno));
  }
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(path + ": cannot open file for reading: " + std::strerror(errno));
  }
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path + ": cannot determine file size (not a regular file?)");
  in.seekg(0, std::ios::beg);
  std::string bytes(static_cast<size_t>(size), '\0');
  if (!in.read(bytes.data(), size)) {
    throw InputError(path + ": read failed after " + std::to_string(in.gcount()) + " of " +
                     std::to_string(size) + " bytes");
  }
  return bytes;
}

}  // namespace mm
