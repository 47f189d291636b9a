// A throwaway PostgreSQL cluster for the tests: initdb into a fresh
// temporary folder, the server listening on a unix socket in that folder
// only (no TCP port to collide with), stopped and removed with the object.
//
// PostgreSQL refuses to run as root; as root (CI) the cluster belongs to
// `nobody` and its programs run through runuser. The binaries are Debian's
// (/usr/lib/postgresql/<version>/bin, the newest found). Not thread safe.
#pragma once

#include <pwd.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace mm::test {

class PostgresCluster {
 public:
  // Throws std::runtime_error with the tool's output when the cluster
  // cannot be created or started.
  PostgresCluster() {
    namespace fs = std::filesystem;
    bin_ = find_bin();
    char pattern[] = "/tmp/mm-pg-XXXXXX";
    if (!mkdtemp(pattern)) throw std::runtime_error("mkdtemp failed");
    dir_ = pattern;
    if (geteuid() == 0) {
      const passwd* nobody = getpwnam("nobody");
      if (!nobody) throw std::runtime_error("no user nobody to run PostgreSQL as");
      if (chown(dir_.c_str(), nobody->pw_uid, nobody->pw_gid) != 0) throw std::runtime_error("chown failed");
      as_user_ = "runuser -u nobody -- ";
    }
    run(bin_ + "/initdb -D " + data() + " -A trust -U mm -E UTF8 --no-sync", "initdb");
    // -F: no fsync, a test cluster need not survive a power cut.
    run(bin_ + "/pg_ctl -D " + data() + " -l " + dir_ + "/server.log -w -t 60 -o \"-k " + dir_ +
            " -c listen_addresses='' -F\" start",
        "pg_ctl start");
    started_ = true;
  }
  ~PostgresCluster() {
    if (started_) {
      std::system((as_user_ + bin_ + "/pg_ctl -D " + data() + " -m immediate -w stop > /dev/null 2>&1").c_str());
    }
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  PostgresCluster(const PostgresCluster&) = delete;
  PostgresCluster& operator=(const PostgresCluster&) = delete;

  // Creates database `name` (owned by user mm); returns its connection URI.
  std::string create_database(const std::string& name) {
    run(bin_ + "/createdb -h " + dir_ + " -U mm " + name, "createdb " + name);
    return uri(name);
  }
  std::string uri(const std::string& database) const {
    return "postgresql:///" + database + "?host=" + dir_ + "&user=mm";
  }

 private:
  static std::string find_bin() {
    std::string best;
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator("/usr/lib/postgresql", error)) {
      const std::string bin = (entry.path() / "bin").string();
      if (std::filesystem::exists(bin + "/initdb") && std::stoi(entry.path().filename().string()) >
                                                          (best.empty() ? 0 : std::stoi(
                                                              std::filesystem::path(best).parent_path().filename().string()))) {
        best = bin;
      }
    }
    if (best.empty()) throw std::runtime_error("no PostgreSQL server in /usr/lib/postgresql (apt-get install postgresql)");
    return best;
  }
  std::string data() const { return dir_ + "/data"; }
  void run(const std::string& command, const std::string& what) {
    const std::string log = dir_ + "/command.log";
    const int status = std::system((as_user_ + command + " > " + log + " 2>&1").c_str());
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      std::ifstream in(log);
      std::string output(std::istreambuf_iterator<char>(in), {});
      std::ifstream server(dir_ + "/server.log");
      output += std::string(std::istreambuf_iterator<char>(server), {});
      throw std::runtime_error(what + " failed:\n" + output);
    }
  }

  std::string bin_, dir_, as_user_;
  bool started_ = false;
};

}  // namespace mm::test
