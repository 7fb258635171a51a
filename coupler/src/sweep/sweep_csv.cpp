// The sweep's results: one row per run, read from its run_report.json (or,
// when the run wrote none, from its exit code and log), and sweep.csv.
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/sweep/sweep.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {

std::vector<std::string> nonEmptyLines(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (line.find_first_not_of(" \t\r") != std::string::npos) lines.push_back(line);
  return lines;
}

// A run without a report: exit 2 means its scene did not validate (the first
// lines of the log say why); otherwise the log's last line is the best clue.
void fillFromLog(SweepRow& row, const fs::path& runDir) {
  row.status = row.exitCode == 2 ? "refused" : "failed";
  const auto lines = nonEmptyLines(runDir / "coupler.log");
  std::string why = lines.empty() ? std::string("no run_report.json and an empty coupler.log")
                                  : (row.exitCode == 2 ? lines.front() : lines.back());
  if (row.exitCode > 128) why = "ended by signal " + std::to_string(row.exitCode - 128) + ": " + why;
  row.message = why;
}

std::optional<double> numberAt(const nlohmann::json& j, const std::string& key) {
  if (j.is_object() && j.contains(key) && j[key].is_number()) return j[key].get<double>();
  return std::nullopt;
}

void fillFromReport(SweepRow& row, const nlohmann::json& report) {
  row.status = report.value("status", std::string("unknown"));
  row.message = report.value("message", std::string());
  if (report.contains("wall_s")) {
    row.wallS = numberAt(report["wall_s"], "total");
    row.loopS = numberAt(report["wall_s"], "exchange_loop");
  }
  row.overheadShare = numberAt(report, "coupling_overhead_share");
  if (report.contains("errors") && report["errors"].is_array() && !report["errors"].empty()) {
    const auto& first = report["errors"][0];
    row.errorName = first.value("name", std::string());
    row.errorValue = numberAt(first, "value");
  }
  if (report.contains("figures") && report["figures"].is_object())
    for (const auto& [name, value] : report["figures"].items())
      if (value.is_number()) row.figures[name] = value.get<double>();
}

std::string csvField(std::string text) {
  for (auto& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  if (text.find_first_of(",\"") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string csvNumber(const std::optional<double>& v) { return v ? config::formatNumber(*v) : std::string(); }

std::string csvLine(const std::vector<std::string>& fields) {
  std::string line;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i) line.push_back(',');
    line.append(csvField(fields[i]));
  }
  line.push_back('\n');
  return line;
}

std::vector<std::string> rowFields(const SweepRow& row, const std::set<std::string>& figures) {
  std::vector<std::string> f{std::to_string(row.index)};
  for (const auto& [key, value] : row.point) f.push_back(value);
  f.insert(f.end(), {row.status, std::to_string(row.exitCode), csvNumber(row.wallS), csvNumber(row.loopS),
                     csvNumber(row.overheadShare), row.errorName, csvNumber(row.errorValue)});
  for (const auto& name : figures) {
    const auto it = row.figures.find(name);
    f.push_back(it == row.figures.end() ? std::string() : config::formatNumber(it->second));
  }
  f.push_back(row.runDir);
  f.push_back(row.message);
  return f;
}

}  // namespace

SweepRow readSweepRow(std::size_t index, const SweepPoint& point, const fs::path& runDir, int exitCode) {
  SweepRow row;
  row.index = index;
  row.point = point;
  row.runDir = runDir.string();
  row.exitCode = exitCode;
  std::ifstream in(runDir / "run_report.json");
  if (!in) {
    fillFromLog(row, runDir);
    return row;
  }
  try {
    fillFromReport(row, nlohmann::json::parse(in));
  } catch (const nlohmann::json::exception& e) {
    row.status = "failed";
    row.message = (runDir / "run_report.json").string() + " is not readable JSON: " + e.what();
  }
  return row;
}

void writeSweepCsv(const fs::path& path, const std::vector<SweepAxis>& axes, const std::vector<SweepRow>& rows) {
  std::set<std::string> figures;
  for (const auto& row : rows)
    for (const auto& [name, value] : row.figures) figures.insert(name);
  std::vector<std::string> header{"index"};
  for (const auto& axis : axes) header.push_back(axis.key);
  header.insert(header.end(), {"status", "exit_code", "wall_s", "exchange_loop_s", "coupling_overhead_share",
                               "error_name", "error_value"});
  header.insert(header.end(), figures.begin(), figures.end());
  header.insert(header.end(), {"run_dir", "message"});
  // Written whole to a temporary file and renamed, so a reader never sees half a table.
  const fs::path partial = path.string() + ".partial";
  {
    std::ofstream out(partial);
    out << csvLine(header);
    for (const auto& row : rows) out << csvLine(rowFields(row, figures));
    out.close();
    if (!out) throw std::runtime_error(partial.string() + ": cannot write the sweep table");
  }
  fs::rename(partial, path);
}

}  // namespace cosim::coupler
