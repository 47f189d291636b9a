// Threads a test starts, stopped and joined however the test ends.
//
// Why: a std::thread still joinable when it is destroyed, or an exception
// that leaves a thread's function, calls std::terminate and ends the whole
// test binary, so one failing call (an activation that throws while clients
// are running) hides the results of every test after it. Here an exception
// in a thread is reported as that test's failure, and the test body's own
// exception or failed ASSERT stops the threads (the stop function) and
// joins them while the stack unwinds, so GoogleTest reports it and goes on.
//
// Not thread-safe itself: start and join from the test's thread only.
#pragma once

#include <exception>
#include <functional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace mm::test {

class JoinedThreads {
 public:
  // `stop` is called once before joining: it tells loops that run until
  // told (an atomic flag) to end. Threads that end by themselves need none.
  explicit JoinedThreads(std::function<void()> stop = {}) : stop_(std::move(stop)) {}
  JoinedThreads(const JoinedThreads&) = delete;
  JoinedThreads& operator=(const JoinedThreads&) = delete;
  ~JoinedThreads() { join(); }

  template <class Body>
  void start(Body body) {
    threads_.emplace_back([body = std::move(body)]() mutable {
      try {
        body();
      } catch (const std::exception& e) {
        ADD_FAILURE() << "a test thread threw: " << e.what();
      } catch (...) {
        ADD_FAILURE() << "a test thread threw something that is not a std::exception";
      }
    });
  }

  // Stops and joins every thread started so far; later calls do nothing
  // until more are started.
  void join() {
    if (threads_.empty()) return;
    if (stop_) stop_();
    for (auto& thread : threads_) thread.join();
    threads_.clear();
  }

 private:
  std::function<void()> stop_;
  std::vector<std::thread> threads_;
};

}  // namespace mm::test
