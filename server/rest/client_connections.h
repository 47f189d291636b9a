// The REST connections open from each client address, capped: one address
// cannot hold more than its share of the REST workers (each connection holds
// one while its request arrives), so that slow or idle connections from one
// client leave the others, and the probes, served.
//
// Thread safety: every method may be called from any thread.
#pragma once

#include <cstddef>
#include <mutex>
#include <string>
#include <unordered_map>

namespace mm::service::rest {

class ClientConnections {
 public:
  explicit ClientConnections(size_t max_per_client) : max_per_client_(max_per_client) {}

  // A connection counted against its address while the Slot lives.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& other) noexcept : owner_(other.owner_), address_(std::move(other.address_)) { other.owner_ = nullptr; }
    Slot& operator=(Slot&&) = delete;
    Slot(const Slot&) = delete;
    ~Slot();
    explicit operator bool() const { return owner_ != nullptr; }

   private:
    friend class ClientConnections;
    Slot(ClientConnections* owner, std::string address) : owner_(owner), address_(std::move(address)) {}
    ClientConnections* owner_ = nullptr;
    std::string address_;
  };

  // A slot for one more connection from `address`; an empty one when the
  // address already has max_per_client() open.
  Slot admit(const std::string& address);
  size_t max_per_client() const { return max_per_client_; }

 private:
  void release(const std::string& address);

  const size_t max_per_client_;
  std::mutex mutex_;
  std::unordered_map<std::string, size_t> open_;  // guarded by mutex_; addresses with none are erased
};

}  // namespace mm::service::rest
