#include "cosim/coupler/analysis/progress.hpp"

#include <unistd.h>

#include <cstdio>

#include "cosim/wire/clock.hpp"

namespace cosim::coupler {

ProgressLine::ProgressLine(bool enabled)
    : enabled_(enabled), terminal_(::isatty(STDERR_FILENO) == 1), start_(monotonicSeconds()), lastPrint_(start_) {}

void ProgressLine::update(double time, double endTime, std::uint64_t exchange, std::uint64_t total) {
  if (!enabled_) return;
  const double now = monotonicSeconds();
  const double every = terminal_ ? 0.2 : 5.0;
  if (now - lastPrint_ < every && exchange != total) return;
  lastPrint_ = now;
  const double elapsed = now - start_;
  const double rate = elapsed > 0 ? static_cast<double>(exchange) / elapsed : 0.0;
  const double eta = rate > 0 ? static_cast<double>(total - exchange) / rate : 0.0;
  std::fprintf(stderr, "%st = %.6g / %.6g s  exchange %llu/%llu  %.0f exch/s  ETA %.1f s%s",
               terminal_ ? "\r" : "", time, endTime, static_cast<unsigned long long>(exchange),
               static_cast<unsigned long long>(total), rate, eta, terminal_ ? "   " : "\n");
  std::fflush(stderr);
  printed_ = true;
}

void ProgressLine::finish() {
  if (enabled_ && terminal_ && printed_) std::fprintf(stderr, "\n");
}

}  // namespace cosim::coupler
