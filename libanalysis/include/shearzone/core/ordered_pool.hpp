// shearzone/core/ordered_pool.hpp: jobs run on worker threads and handed back in the
// order they were submitted, so that what the caller writes is the same as one job at a
// time, for any number of workers.
//
//     core::OrderedPool<PairJob> pool([&](PairJob& j) { j.result = work(j); }, threads);
//     pool.submit(job);                       // while !pool.full()
//     while (auto done = pool.pop_done(false)) write(*done);   // in submission order
//
// A job's exception is caught on its worker and rethrown by pop_done() in its turn.
// The caller keeps at most `workers + 2` jobs in flight (full(), pop_done(true)) and
// does its own work (decoding the next frames) meanwhile.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace shearzone::core {

template <class Job>
class OrderedPool {
 public:
  /// `run` does a job in place on a worker thread; `on_start` runs first in each worker
  /// (e.g. to set its OpenMP thread count).
  OrderedPool(std::function<void(Job&)> run, int workers, std::function<void()> on_start = {})
      : run_(std::move(run)), on_start_(std::move(on_start)), capacity_(static_cast<std::size_t>(workers) + 2) {
    for (int i = 0; i < workers; ++i) threads_.emplace_back([this] { work(); });
  }
  ~OrderedPool() {
    {
      std::lock_guard lock(m_);
      stop_ = true;
    }
    todo_.notify_all();
    for (auto& t : threads_) t.join();
  }
  OrderedPool(const OrderedPool&) = delete;
  OrderedPool& operator=(const OrderedPool&) = delete;

  /// Whether `workers + 2` jobs are queued or running: pop one before submitting more.
  bool full() {
    std::lock_guard lock(m_);
    return slots_.size() >= capacity_;
  }
  void submit(Job job) {
    auto s = std::make_shared<Slot>();
    s->job = std::move(job);
    std::lock_guard lock(m_);
    slots_.push_back(std::move(s));
    todo_.notify_one();
  }
  /// The oldest job once done (waiting for it if `wait`); nothing if none is ready (or
  /// none is left). Rethrows the job's exception.
  std::optional<Job> pop_done(bool wait) {
    std::shared_ptr<Slot> s;
    {
      std::unique_lock lock(m_);
      if (wait) finished_.wait(lock, [&] { return slots_.empty() || slots_.front()->done; });
      if (slots_.empty() || !slots_.front()->done) return std::nullopt;
      s = std::move(slots_.front());
      slots_.pop_front();
      --next_;
    }
    if (s->error) std::rethrow_exception(s->error);
    return std::move(s->job);
  }

 private:
  struct Slot {
    Job job;
    std::exception_ptr error;
    bool done = false;
  };
  void work() {
    if (on_start_) on_start_();
    for (;;) {
      std::shared_ptr<Slot> s;
      {
        std::unique_lock lock(m_);
        todo_.wait(lock, [&] { return stop_ || next_ < slots_.size(); });
        if (stop_) return;
        s = slots_[next_++];
      }
      try {
        run_(s->job);
      } catch (...) {
        s->error = std::current_exception();
      }
      {
        std::lock_guard lock(m_);
        s->done = true;
      }
      finished_.notify_all();
    }
  }

  std::function<void(Job&)> run_;
  std::function<void()> on_start_;
  const std::size_t capacity_;
  std::mutex m_;
  std::condition_variable todo_, finished_;
  std::deque<std::shared_ptr<Slot>> slots_;  // submission order
  std::size_t next_ = 0;                     // index in slots_ of the next to start
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace shearzone::core
