#include "server/rest/client_connections.h"

namespace mm::service::rest {

ClientConnections::Slot::~Slot() {
  if (owner_ != nullptr) owner_->release(address_);
}

ClientConnections::Slot ClientConnections::admit(const std::string& address) {
  std::lock_guard<std::mutex> lock(mutex_);
  size_t& open = open_[address];
  if (open >= max_per_client_) {
    if (open == 0) open_.erase(address);
    return Slot();
  }
  ++open;
  return Slot(this, address);
}

void ClientConnections::release(const std::string& address) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = open_.find(address);
  if (found == open_.end()) return;
  if (--found->second == 0) open_.erase(found);
}

}  // namespace mm::service::rest
