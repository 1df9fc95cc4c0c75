#pragma once
// Private: one background thread running jobs in submission order, with a bounded backlog (so a
// slow disk throttles the producer instead of filling memory). The first exception of a job is
// re-thrown by the next push() or by finish(); later jobs are skipped. Destroying the queue
// without finish() drops the backlog and joins (the error path).
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace obm::sim::detail {

class WorkQueue {
 public:
  explicit WorkQueue(std::size_t max_pending) : max_(max_pending), th_([this] { loop(); }) {}
  ~WorkQueue() { stop(false); }
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  void push(std::function<void()> job) {
    std::unique_lock<std::mutex> lk(m_);
    space_.wait(lk, [&] { return q_.size() < max_ || error_; });
    if (error_) std::rethrow_exception(error_);
    q_.push_back(std::move(job));
    ready_.notify_one();
  }

  /// Runs the backlog to the end, then re-throws the first job error, if any.
  void finish() {
    stop(true);
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void loop() {
    for (;;) {
      std::function<void()> job;
      bool failed;
      {
        std::unique_lock<std::mutex> lk(m_);
        ready_.wait(lk, [&] { return !q_.empty() || stopping_; });
        if (q_.empty()) return;
        job = std::move(q_.front());
        q_.pop_front();
        failed = static_cast<bool>(error_);
      }
      if (!failed) {
        try {
          job();
        } catch (...) {
          std::lock_guard<std::mutex> lk(m_);
          if (!error_) error_ = std::current_exception();
        }
      }
      space_.notify_all();
    }
  }

  void stop(bool drain) {
    {
      std::lock_guard<std::mutex> lk(m_);
      if (!drain) q_.clear();
      stopping_ = true;
    }
    ready_.notify_all();
    if (th_.joinable()) th_.join();
  }

  std::size_t max_;
  std::mutex m_;
  std::condition_variable ready_, space_;
  std::deque<std::function<void()>> q_;
  std::exception_ptr error_;
  bool stopping_ = false;
  std::thread th_;
};

}  // namespace obm::sim::detail
