#pragma once
// `coupler sweep`: one scene over a grid of --set values. Every point of the
// cartesian product is a separate `coupler run` child process (the same
// binary) with its own run directory and log; the sweep collects each run's
// run_report.json into sweep.csv and plots error against wall time
// (DESIGN.md 6.4: how every benchmark reports its result).
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace cosim::coupler {

/// One swept key and its values, in the order given.
struct SweepAxis {
  std::string key;
  std::vector<std::string> values;
};

struct SweepOptions {
  std::string scenePath;
  std::vector<SweepAxis> axes;
  std::string outDir;  // empty: runs/<scene file stem>-sweep
  int jobs = 1;        // runs at once
  bool force = false;  // passed on to every run
};

/// One combination: (key, value) per axis, in axis order.
using SweepPoint = std::vector<std::pair<std::string, std::string>>;

/// "a,b,[1,2]" -> a | b | [1,2]: commas inside [] {} or quotes do not split.
/// Throws std::invalid_argument naming the argument (empty value, unbalanced bracket).
std::vector<std::string> splitSweepValues(const std::string& list, const std::string& argument);

/// "key=v1,v2" -> the axis; throws std::invalid_argument.
SweepAxis parseSweepAxis(const std::string& argument);

/// The sweep's command line after `sweep`; throws std::invalid_argument naming the bad argument.
SweepOptions parseSweepArguments(const std::vector<std::string>& args);

/// The cartesian product, the first axis varying slowest.
std::vector<SweepPoint> sweepPoints(const std::vector<SweepAxis>& axes);

/// "<index>_<key=value>_<key=value>": the index zero-padded to the width of
/// count - 1, characters other than letters, digits and . _ = + - replaced by '_'.
std::string runDirectoryName(std::size_t index, std::size_t count, const SweepPoint& point);

/// What sweep.csv holds about one run.
struct SweepRow {
  std::size_t index = 0;
  SweepPoint point;
  std::string runDir;
  std::string status;  // completed, refused, failed, interrupted
  int exitCode = -1;
  std::optional<double> wallS, loopS, overheadShare, errorValue;
  std::string errorName;
  std::map<std::string, double> figures;
  std::string message;
};

/// The row of a finished run from its run_report.json; without one (the scene
/// did not validate, or the run crashed) from its exit code and coupler.log.
SweepRow readSweepRow(std::size_t index, const SweepPoint& point, const std::filesystem::path& runDir, int exitCode);

/// Columns: index, one per swept key, status, exit_code, wall_s,
/// exchange_loop_s, coupling_overhead_share, error_name, error_value, every
/// figure (the union over the rows, empty where a run has none), run_dir, message.
void writeSweepCsv(const std::filesystem::path& path, const std::vector<SweepAxis>& axes,
                   const std::vector<SweepRow>& rows);

/// Runs the sweep; returns 0 when every run completed, 1 otherwise, 2 when the
/// arguments or the scene cannot be used, 130 when interrupted.
int sweepMain(const SweepOptions& options);

}  // namespace cosim::coupler
