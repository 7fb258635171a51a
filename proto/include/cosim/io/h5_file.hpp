#pragma once
// HDF5 output every process shares: one file per process, time series under
// /series as chunked, extendible datasets (one row per record), snapshots
// under /snapshots/<step>, attributes for units and parameters. flush() after
// each output interval bounds what a crash can lose to one interval.
#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace cosim::io {

class H5File {
 public:
  /// Creates (truncates) path for writing.
  static H5File create(const std::filesystem::path& path);
  static H5File openReadOnly(const std::filesystem::path& path);
  /// Opens an existing file for writing (a resumed run continues its file).
  static H5File openForAppend(const std::filesystem::path& path);
  /// A solver's snapshot file: kept and opened for appending when `keep` and
  /// it exists (a resumed run), created otherwise.
  static H5File createOrKeep(const std::filesystem::path& path, bool keep);
  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&& other) noexcept;
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;
  ~H5File();

  hid_t id() const { return file_; }
  const std::filesystem::path& path() const { return path_; }
  /// Opens or creates a group, with its parents ("/snapshots/100").
  hid_t group(const std::string& path);
  void setAttribute(const std::string& object, const std::string& name, double value);
  void setAttribute(const std::string& object, const std::string& name, const std::string& value);
  /// Writes a fixed 2-D dataset rows x cols (cols = 1 writes a 1-D dataset).
  void writeArray(const std::string& path, std::span<const double> values, std::size_t cols = 1);
  void writeArray(const std::string& path, std::span<const std::uint32_t> values, std::size_t cols = 1);
  /// Reads a whole dataset as doubles (for tests and restarts).
  std::vector<double> readArray(const std::string& path) const;
  std::vector<std::size_t> shape(const std::string& path) const;
  bool exists(const std::string& path) const;
  /// A double attribute, or `fallback` when the object has none.
  double attribute(const std::string& object, const std::string& name, double fallback) const;
  /// Names of the links directly under a group (empty when it does not exist).
  std::vector<std::string> children(const std::string& group) const;
  /// Replaces the file by a copy without the objects at `drop` (and below
  /// them), then reopens it for appending: how a resumed run drops what it
  /// will write again. Unlinking in place is not enough there: a process
  /// killed while writing leaves objects whose headers never reached the disk,
  /// and HDF5 can neither unlink nor reuse those. Open groups are closed.
  void rewriteWithout(const std::vector<std::string>& drop);
  void flush();

 private:
  H5File(hid_t file, std::filesystem::path path) : file_(file), path_(std::move(path)) {}
  void close();
  hid_t file_ = -1;
  std::filesystem::path path_;
  std::map<std::string, hid_t> groups_;
};

/// Appends rows to datasets under one group; each column count is fixed at
/// its first append. Rows are buffered and written by flush() (one extent
/// change and one write per dataset), then the file is flushed.
class SeriesWriter {
 public:
  SeriesWriter(H5File& file, std::string group = "/series");
  ~SeriesWriter();
  SeriesWriter(const SeriesWriter&) = delete;
  SeriesWriter& operator=(const SeriesWriter&) = delete;
  void append(const std::string& name, double value);
  void append(const std::string& name, std::span<const double> row);
  /// Sets a units attribute on a series (created on first append).
  void setUnits(const std::string& name, const std::string& units);
  /// Adopts every series already under the group, cut to its first `rows`
  /// rows, so that appends continue a resumed run where its checkpoint was.
  void resumeAt(std::size_t rows);
  /// The same, with each series cut to its own row count (series appended
  /// on some rows only, e.g. per coarse step); a series not listed started
  /// after the checkpoint and is cut to none.
  void resumeAt(const std::map<std::string, std::size_t>& rowsOf);
  std::size_t rows(const std::string& name) const;
  /// Every series' row count, appended rows included (what a checkpoint records).
  std::map<std::string, std::size_t> rowCounts() const;
  void flush();

 private:
  struct Dataset {
    hid_t id = -1;
    std::size_t cols = 0;
    std::size_t rows = 0;     // written to the file
    std::vector<double> pending;  // appended, not yet written
  };
  Dataset& dataset(const std::string& name, std::size_t cols);
  void resumeWith(const std::function<std::size_t(const std::string&)>& rowsOf);
  H5File& file_;
  std::string group_;
  std::map<std::string, Dataset> datasets_;
  std::map<std::string, std::string> pendingUnits_;
};

}  // namespace cosim::io
