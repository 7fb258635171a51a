#pragma once
#include <chrono>

namespace cosim {

/// Seconds on the monotonic clock (for deadlines, heartbeats and timings).
inline double monotonicSeconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

/// Accumulates wall time over scopes: `{ ScopedTimer t(total); ... }`.
class ScopedTimer {
 public:
  explicit ScopedTimer(double& total) : total_(total), start_(monotonicSeconds()) {}
  ~ScopedTimer() { total_ += monotonicSeconds() - start_; }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& total_;
  double start_;
};

}  // namespace cosim
