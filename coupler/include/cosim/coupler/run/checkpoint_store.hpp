#pragma once
// The run's checkpoints: checkpoints/exchange-<k>/ holds every solver's own
// checkpoint file (<solver>.chk), each solver's last reply (<solver>.last.bin,
// from which the couplings restage the next inputs), the reference solution's
// state (analysis.bin), the couplings' state (couplings.bin), the workers the
// run lost (lost_solvers.txt) and the scene text. The
// directory becomes visible under its final name only once complete, so a
// crash while checkpointing never leaves a half checkpoint to resume from.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>

namespace cosim::coupler {

class CheckpointStore {
 public:
  explicit CheckpointStore(std::filesystem::path runDir, int keep = 2);

  struct Point {
    std::uint64_t exchange = 0;
    double time = 0.0;
    std::filesystem::path dir;
    // Rows of each /series dataset at the checkpoint (absent where the
    // checkpoint does not record them: every series then has one row per record).
    std::optional<std::map<std::string, std::size_t>> seriesRows;
  };

  /// A fresh directory for the checkpoint at this exchange (not yet visible).
  std::filesystem::path begin(std::uint64_t exchange);
  /// Records the coupler's own state, makes the checkpoint visible, drops old ones.
  Point commit(std::uint64_t exchange, double time, const std::string& sceneText,
               const std::map<std::string, std::size_t>& seriesRows);
  /// The newest complete checkpoint, if any.
  std::optional<Point> latest() const;
  /// The scene text a checkpoint was taken with.
  static std::string sceneText(const Point& point);

  static std::filesystem::path solverCheckpoint(const std::filesystem::path& dir, const std::string& solver);
  static std::filesystem::path solverLastReply(const std::filesystem::path& dir, const std::string& solver);
  /// The scene's reference solution's state (analysis.bin), when it has one.
  static std::filesystem::path analysisState(const std::filesystem::path& dir);
  /// The couplings' counts (couplings.bin), when one of them keeps any.
  static std::filesystem::path couplingState(const std::filesystem::path& dir);
  /// The workers the run lost and moved the work of (lost_solvers.txt, one
  /// name per line; absent: none): a resumed run does not start them.
  static void saveLostSolvers(const std::filesystem::path& dir, const std::set<std::string>& lost);
  static std::set<std::string> lostSolvers(const std::filesystem::path& dir);

 private:
  std::filesystem::path root_;
  int keep_;
};

}  // namespace cosim::coupler
