#include "posekit/core/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace posekit {

int resolve_threads(int requested) {
  return requested > 0 ? requested : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void parallel_for_ranges(long n, int threads, const std::function<void(long, long)>& body, long min_items_per_thread) {
  threads = static_cast<int>(std::min<long>(resolve_threads(threads), std::max<long>(1, n / std::max<long>(1, min_items_per_thread))));
  if (threads <= 1) {
    body(0, n);
    return;
  }
  // An exception in any range is rethrown here after every thread has joined (never std::terminate).
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(static_cast<size_t>(threads));
  auto guarded = [&](int t, long begin, long end) {
    try {
      body(begin, end);
    } catch (...) {
      errors[static_cast<size_t>(t)] = std::current_exception();
    }
  };
  const long chunk = (n + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    const long begin = t * chunk, end = std::min(n, begin + chunk);
    if (begin < end) pool.emplace_back(guarded, t, begin, end);
  }
  guarded(0, 0, std::min(n, chunk));
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

void parallel_for_each(long n, int threads, const std::function<void(long)>& item) {
  threads = static_cast<int>(std::min<long>(resolve_threads(threads), std::max<long>(1, n)));
  std::atomic<long> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  auto worker = [&] {
    for (long i = next++; i < n; i = next++) {
      try {
        item(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = n;  // no new item starts
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

void run_beside(int threads, const std::function<void()>& beside, const std::function<void()>& main) {
  std::exception_ptr beside_error, main_error;
  auto run_main = [&] {
    try {
      main();
    } catch (...) {
      main_error = std::current_exception();
    }
  };
  auto run_beside_work = [&] {
    try {
      beside();
    } catch (...) {
      beside_error = std::current_exception();
    }
  };
  if (resolve_threads(threads) < 2) {
    run_beside_work();
    run_main();
  } else {
    std::thread side(run_beside_work);
    run_main();
    side.join();
  }
  if (main_error) std::rethrow_exception(main_error);
  if (beside_error) std::rethrow_exception(beside_error);
}

}  // namespace posekit
