// A loop over independent items on a few threads (decoding and writing many motions, parsing many
// files). No LibTorch.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

namespace mosyn {

// Runs body(i) for every i in [0, n) on min(threads, n) threads (the caller's among them), items
// handed out one at a time. body must be safe to run concurrently for different i. After the first
// item that throws no new item starts; the exception of the lowest failing index is rethrown once
// every thread has stopped. threads < 1 counts as 1.
template <typename Body>
void parallel_for(int n, int threads, Body body) {
  std::vector<std::exception_ptr> errors(static_cast<size_t>(std::max(n, 0)));
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  auto worker = [&] {
    for (int i = next++; i < n && !failed; i = next++) {
      try {
        body(i);
      } catch (...) {
        errors[i] = std::current_exception();
        failed = true;
      }
    }
  };
  const int count = std::max(1, std::min(threads, n));
  std::vector<std::thread> pool;
  for (int k = 1; k < count; ++k) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

// The cores this machine offers (at least 1).
inline int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace mosyn
