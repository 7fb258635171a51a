#pragma once
// The progress line on stderr: simulated time, exchanges per second, ETA.
// On a terminal it rewrites one line; otherwise it prints a line every few seconds.
#include <cstdint>

namespace cosim::coupler {

class ProgressLine {
 public:
  explicit ProgressLine(bool enabled);
  void update(double time, double endTime, std::uint64_t exchange, std::uint64_t total);
  void finish();

 private:
  bool enabled_;
  bool terminal_;
  double start_;
  double lastPrint_ = 0.0;
  bool printed_ = false;
};

}  // namespace cosim::coupler
