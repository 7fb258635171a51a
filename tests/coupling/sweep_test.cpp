// `coupler sweep`: value lists, the product, run directory names, the CSV
// (unit); real sweeps of the mock demo scene (rows, run directories, a
// refused value that does not stop the sweep, plots); the plot script.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cosim/coupler/sweep/sweep.hpp"
#include "cosim/util/cpu_affinity.hpp"
#include "subprocess.hpp"

namespace fs = std::filesystem;
using cosim::coupler::parseSweepArguments;
using cosim::coupler::SweepAxis;
using cosim::coupler::SweepRow;

namespace {

using Table = std::vector<std::map<std::string, std::string>>;

// RFC 4180 fields: quoted fields may hold commas and doubled quotes.
std::vector<std::string> csvFields(const std::string& line) {
  std::vector<std::string> fields{""};
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') fields.back() += line[++i];
    else if (c == '"') quoted = !quoted;
    else if (c == ',' && !quoted) fields.emplace_back();
    else fields.back() += c;
  }
  return fields;
}

struct Csv {
  std::vector<std::string> header;
  Table rows;
};

Csv readCsv(const fs::path& path) {
  std::ifstream in(path);
  Csv csv;
  std::string line;
  if (!std::getline(in, line)) return csv;
  csv.header = csvFields(line);
  while (std::getline(in, line)) {
    const auto fields = csvFields(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < fields.size() && i < csv.header.size(); ++i) row[csv.header[i]] = fields[i];
    EXPECT_EQ(fields.size(), csv.header.size()) << line;
    csv.rows.push_back(row);
  }
  return csv;
}

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

bool matplotlibAvailable() {
  if (!fs::exists("/usr/bin/python3")) return false;
  return cosim::testing::run({"/usr/bin/python3", "-c", "import matplotlib"}, 30.0).code == 0;
}

bool isPng(const fs::path& path) { return readText(path).rfind("\x89PNG", 0) == 0; }

std::string demoScene() { return cosim::testing::sourcePath("configs/demo/two_mocks.yaml"); }

cosim::testing::Finished sweep(const std::vector<std::string>& arguments) {
  std::vector<std::string> argv{cosim::testing::binary("coupler"), "sweep"};
  argv.insert(argv.end(), arguments.begin(), arguments.end());
  return cosim::testing::run(argv, 60.0);
}

}  // namespace

TEST(SweepArguments, CommasInsideBracketsAndQuotesDoNotSplit) {
  using cosim::coupler::splitSweepValues;
  EXPECT_EQ(splitSweepValues("1e-3,2e-3", "x"), (std::vector<std::string>{"1e-3", "2e-3"}));
  EXPECT_EQ(splitSweepValues("[0,0,-9.81], [1,2,3]", "x"), (std::vector<std::string>{"[0,0,-9.81]", "[1,2,3]"}));
  EXPECT_EQ(splitSweepValues("{a: 1, b: [2,3]},x", "x"), (std::vector<std::string>{"{a: 1, b: [2,3]}", "x"}));
  EXPECT_EQ(splitSweepValues("'a,b',\"c,d\",e", "x"), (std::vector<std::string>{"'a,b'", "\"c,d\"", "e"}));
  for (const std::string bad : {"1,,2", "1,", "[1,2", "1]", "'a,b", ""})
    EXPECT_THROW(splitSweepValues(bad, "k=" + bad), std::invalid_argument) << bad;
}

TEST(SweepArguments, CommandLineIsCheckedBeforeAnythingRuns) {
  const auto options = parseSweepArguments({"s.yaml", "--set", "schedule.dt=1,2", "--set", "a.b=[1,2],x", "--jobs", "3",
                                            "--out", "dir", "--force"});
  EXPECT_EQ(options.scenePath, "s.yaml");
  ASSERT_EQ(options.axes.size(), 2u);
  EXPECT_EQ(options.axes[1].key, "a.b");
  EXPECT_EQ(options.axes[1].values, (std::vector<std::string>{"[1,2]", "x"}));
  EXPECT_EQ(options.jobs, 3);
  EXPECT_EQ(options.outDir, "dir");
  EXPECT_TRUE(options.force);
  const std::vector<std::vector<std::string>> bad{
      {"--set", "a=1"},                                       // no scene
      {"s.yaml"},                                             // nothing to sweep
      {"s.yaml", "--set", "a=1", "--jobs", "0"},              // no runs at once
      {"s.yaml", "--set", "a=1", "--jobs", "two"},            //
      {"s.yaml", "--set", "a=1", "--set", "a=2"},             // a key twice
      {"s.yaml", "--set", "a=1,1"},                           // a value twice
      {"s.yaml", "--set", "a..b=1"},                          // not a key path
      {"s.yaml", "--set", "a=1", "--resume"},                 // not a sweep option
      {"s.yaml", "t.yaml", "--set", "a=1"},                   // two scenes
      {"s.yaml", "--set"}};                                   // no value
  for (const auto& args : bad) {
    std::string joined;
    for (const auto& a : args) joined += a + " ";
    EXPECT_THROW(parseSweepArguments(args), std::invalid_argument) << joined;
  }
}

TEST(SweepArguments, ProductVariesTheFirstKeySlowest) {
  const auto points = cosim::coupler::sweepPoints({{"a", {"1", "2"}}, {"b", {"x", "y", "z"}}});
  ASSERT_EQ(points.size(), 6u);
  EXPECT_EQ(points[0], (cosim::coupler::SweepPoint{{"a", "1"}, {"b", "x"}}));
  EXPECT_EQ(points[2], (cosim::coupler::SweepPoint{{"a", "1"}, {"b", "z"}}));
  EXPECT_EQ(points[3], (cosim::coupler::SweepPoint{{"a", "2"}, {"b", "x"}}));
}

TEST(SweepArguments, RunDirectoryNamesAreSafeAndOrdered) {
  using cosim::coupler::runDirectoryName;
  EXPECT_EQ(runDirectoryName(3, 12, {{"schedule.dt", "1e-3"}, {"g", "[0, -9.81]"}}), "03_schedule.dt=1e-3_g=_0__-9.81_");
  EXPECT_EQ(runDirectoryName(0, 1, {{"a/b", "../x"}}), "0_a_b=.._x");
  EXPECT_LE(runDirectoryName(1, 2, {{"k", std::string(500, 'v')}}).size(), 120u);
}

TEST(SweepTable, CsvHasOneColumnPerKeyAndTheUnionOfFigures) {
  const auto dir = cosim::testing::freshDirectory("sweep-csv");
  SweepRow first;
  first.index = 0;
  first.point = {{"schedule.dt", "1e-3"}};
  first.status = "completed";
  first.exitCode = 0;
  first.wallS = 1.5;
  first.loopS = 1.25;
  first.overheadShare = 0.5;
  first.errorName = "trajectory_error";
  first.errorValue = 0.125;
  first.figures = {{"peak_force", 3.0}};
  first.runDir = "runs/0";
  SweepRow second;
  second.index = 1;
  second.point = {{"schedule.dt", "[1,2]"}};
  second.status = "refused";
  second.exitCode = 2;
  second.figures = {{"drift", 0.25}};
  second.runDir = "runs/1";
  second.message = "f.yaml:6: schedule.dt: \"bad\", really\nsecond line";
  cosim::coupler::writeSweepCsv(dir / "sweep.csv", {{"schedule.dt", {"1e-3", "[1,2]"}}}, {first, second});
  const auto lines = readText(dir / "sweep.csv");
  EXPECT_EQ(lines,
            "index,schedule.dt,status,exit_code,wall_s,exchange_loop_s,coupling_overhead_share,error_name,error_value,"
            "drift,peak_force,run_dir,message\n"
            "0,1e-3,completed,0,1.5,1.25,0.5,trajectory_error,0.125,,3,runs/0,\n"
            "1,\"[1,2]\",refused,2,,,,,,0.25,,runs/1,\"f.yaml:6: schedule.dt: \"\"bad\"\", really second line\"\n");
  const auto csv = readCsv(dir / "sweep.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.rows[1].at("schedule.dt"), "[1,2]");
  EXPECT_EQ(csv.rows[1].at("message"), "f.yaml:6: schedule.dt: \"bad\", really second line");
  fs::remove_all(dir);
}

TEST(SweepTable, RowsComeFromTheReportOrElseFromTheLog) {
  const auto dir = cosim::testing::freshDirectory("sweep-row");
  fs::create_directories(dir / "a");
  writeText(dir / "a" / "run_report.json",
            R"({"status": "completed", "message": "", "wall_s": {"total": 2.5, "exchange_loop": 2.0},
                "coupling_overhead_share": 0.2,
                "errors": [{"name": "l2", "reference": "analytic", "unit": "m", "value": 0.01},
                           {"name": "other", "reference": "x", "unit": "m", "value": 9}],
                "figures": {"peak": 4.0}})");
  const auto row = cosim::coupler::readSweepRow(0, {{"k", "1"}}, dir / "a", 0);
  EXPECT_EQ(row.status, "completed");
  EXPECT_EQ(row.wallS.value_or(-1), 2.5);
  EXPECT_EQ(row.loopS.value_or(-1), 2.0);
  EXPECT_EQ(row.overheadShare.value_or(-1), 0.2);
  EXPECT_EQ(row.errorName, "l2");
  EXPECT_EQ(row.errorValue.value_or(-1), 0.01);
  EXPECT_EQ(row.figures.at("peak"), 4.0);

  fs::create_directories(dir / "b");
  writeText(dir / "b" / "coupler.log", "\nb/scene.effective.yaml:6: schedule.dt: must be > 0\nsecond problem\n");
  const auto refused = cosim::coupler::readSweepRow(1, {{"k", "2"}}, dir / "b", 2);
  EXPECT_EQ(refused.status, "refused");
  EXPECT_EQ(refused.exitCode, 2);
  EXPECT_EQ(refused.message, "b/scene.effective.yaml:6: schedule.dt: must be > 0");
  EXPECT_FALSE(refused.wallS);

  fs::create_directories(dir / "c");
  const auto killed = cosim::coupler::readSweepRow(2, {{"k", "3"}}, dir / "c", 137);
  EXPECT_EQ(killed.status, "failed");
  EXPECT_NE(killed.message.find("signal 9"), std::string::npos) << killed.message;
  fs::remove_all(dir);
}

TEST(SweepRun, TwoTimeStepsGiveTwoRowsAndTwoRunDirectories) {
  const auto dir = cosim::testing::freshDirectory("sweep-run");
  const auto out = dir / "sweep";
  const auto result = sweep({demoScene(), "--set", "schedule.dt=1e-3,2e-3", "--out", out.string(), "--jobs", "2"});
  ASSERT_EQ(result.code, 0) << result.out << result.err;
  const auto csv = readCsv(out / "sweep.csv");
  ASSERT_EQ(csv.header.size(), 11u);
  EXPECT_EQ(csv.header[1], "schedule.dt");
  ASSERT_EQ(csv.rows.size(), 2u);
  const std::vector<std::string> values{"1e-3", "2e-3"};
  const std::vector<std::string> exchanges{"\"planned_exchanges\": 1000", "\"planned_exchanges\": 500"};
  for (std::size_t i = 0; i < 2; ++i) {
    auto row = csv.rows[i];
    EXPECT_EQ(row["index"], std::to_string(i));
    EXPECT_EQ(row["schedule.dt"], values[i]);
    EXPECT_EQ(row["status"], "completed") << row["message"];
    EXPECT_EQ(row["exit_code"], "0");
    EXPECT_GT(std::stod(row["wall_s"]), 0.0);
    EXPECT_GT(std::stod(row["exchange_loop_s"]), 0.0);
    EXPECT_FALSE(row["coupling_overhead_share"].empty());
    const fs::path run = out / (std::to_string(i) + "_schedule.dt=" + values[i]);
    EXPECT_EQ(fs::path(row["run_dir"]), run);
    EXPECT_NE(readText(run / "run_report.json").find(exchanges[i]), std::string::npos) << run;
    EXPECT_NE(readText(run / "scene.effective.yaml").find("dt: " + values[i]), std::string::npos);
    EXPECT_NE(readText(run / "coupler.log").find("completed"), std::string::npos) << "the run's report goes to its log";
  }
  EXPECT_EQ(result.out.find("run report:"), std::string::npos) << "child output must not reach the terminal";
  EXPECT_NE(result.out.find((out / "sweep.csv").string()), std::string::npos) << result.out;
  if (matplotlibAvailable()) {
    EXPECT_TRUE(isPng(out / "error_vs_walltime.png")) << result.err;
    EXPECT_TRUE(isPng(out / "walltime_vs_schedule.dt.png")) << result.err;
    EXPECT_NE(result.out.find("plot: "), std::string::npos) << result.out;
  }
  fs::remove_all(dir);
}

TEST(SweepRun, PackedRunsStartedTogetherGetACpuEach) {
  const auto dir = cosim::testing::freshDirectory("sweep-packed");
  const auto scene = dir / "packed.yaml";
  {
    std::ofstream f(scene);
    f << readText(demoScene()) << "placement: {processes: packed}\n";
  }
  const auto out = dir / "sweep";
  const auto result =
      sweep({scene.string(), "--set", "schedule.dt=1e-3,2e-3", "--out", out.string(), "--jobs", "2"});
  ASSERT_EQ(result.code, 0) << result.out << result.err;
  const auto allowed = cosim::util::allowedCpus();
  const std::vector<std::string> values{"1e-3", "2e-3"};
  for (std::size_t slot = 0; slot < 2; ++slot) {
    const auto report = readText(out / (std::to_string(slot) + "_schedule.dt=" + values[slot]) / "run_report.json");
    const auto cpu = std::to_string(allowed[slot % allowed.size()]);
    EXPECT_NE(report.find("\"placement\": \"packed on CPUs [" + cpu + "]\""), std::string::npos) << report;
  }
  fs::remove_all(dir);
}

TEST(SweepRun, ARefusedValueIsARowAndTheSweepGoesOn) {
  const auto dir = cosim::testing::freshDirectory("sweep-refused");
  const auto out = dir / "sweep";
  const auto result = sweep({demoScene(), "--set", "schedule.dt=-1e-3,1e-3", "--set", "schedule.end_time=0.1", "--out",
                             out.string()});
  EXPECT_EQ(result.code, 1) << result.out << result.err;
  const auto csv = readCsv(out / "sweep.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  auto refused = csv.rows[0];
  EXPECT_EQ(refused["schedule.dt"], "-1e-3");
  EXPECT_EQ(refused["schedule.end_time"], "0.1");
  EXPECT_EQ(refused["status"], "refused");
  EXPECT_EQ(refused["exit_code"], "2");
  EXPECT_TRUE(refused["wall_s"].empty());
  EXPECT_NE(refused["message"].find("scene.effective.yaml:"), std::string::npos) << refused["message"];
  EXPECT_NE(refused["message"].find("schedule.dt"), std::string::npos) << refused["message"];
  auto completed = csv.rows[1];
  EXPECT_EQ(completed["status"], "completed") << completed["message"];
  EXPECT_EQ(completed["exit_code"], "0");
  fs::remove_all(dir);
}

TEST(SweepRun, AKeyThatDoesNotApplyIsAUsageErrorAndStartsNothing) {
  const auto dir = cosim::testing::freshDirectory("sweep-bad");
  const auto out = dir / "sweep";
  const auto result = sweep({demoScene(), "--set", "schedule.nokey.dt=1,2", "--out", out.string()});
  EXPECT_EQ(result.code, 2);
  EXPECT_NE(result.err.find("--set 'schedule.nokey.dt=1': schedule has no key 'nokey'"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(out));
  const auto noValues = sweep({demoScene(), "--out", out.string()});
  EXPECT_EQ(noValues.code, 2);
  EXPECT_NE(noValues.err.find("--set"), std::string::npos) << noValues.err;
  const auto noScene = sweep({(dir / "missing.yaml").string(), "--set", "schedule.dt=1", "--out", out.string()});
  EXPECT_EQ(noScene.code, 2);
  EXPECT_NE(noScene.err.find("missing.yaml: cannot open the scene file"), std::string::npos) << noScene.err;
  fs::remove_all(dir);
}

TEST(PlotSweep, WritesTheErrorPlotAndOnePlotPerFigure) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  const auto dir = cosim::testing::freshDirectory("sweep-plot");
  writeText(dir / "sweep.csv",
            "index,cg.width,schedule.dt,status,exit_code,wall_s,exchange_loop_s,coupling_overhead_share,error_name,"
            "error_value,peak_force,run_dir,message\n"
            "0,1d,1e-3,completed,0,1.5,1.2,0.1,trajectory_error,0.2,5.5,a,\n"
            "1,1d,2e-3,completed,0,0.8,0.6,0.1,trajectory_error,0.4,5.1,b,\n"
            "2,2d,1e-3,completed,0,2.5,2.2,0.1,trajectory_error,0.05,4.5,c,\n"
            "3,2d,2e-3,refused,2,,,,,,,d,\"bad, really\"\n");
  const auto script = cosim::testing::sourcePath("scripts/plot_sweep.py");
  const auto plot = cosim::testing::run({"/usr/bin/python3", script, (dir / "sweep.csv").string()}, 60.0);
  if (matplotlibAvailable()) {
    ASSERT_EQ(plot.code, 0) << plot.err;
    for (const auto* png : {"error_vs_walltime.png", "walltime_vs_cg.width.png", "peak_force_vs_cg.width.png"}) {
      EXPECT_TRUE(isPng(dir / png)) << png;
      EXPECT_NE(plot.out.find((dir / png).string()), std::string::npos) << plot.out;
    }
  } else {
    EXPECT_EQ(plot.code, 3) << plot.err;
    EXPECT_NE(plot.err.find("matplotlib"), std::string::npos) << plot.err;
  }
  writeText(dir / "other.csv", "a,b\n1,2\n");
  const auto notATable = cosim::testing::run({"/usr/bin/python3", script, (dir / "other.csv").string()}, 60.0);
  EXPECT_EQ(notATable.code, 2);
  EXPECT_NE(notATable.err.find("is not a sweep table"), std::string::npos) << notATable.err;
  fs::remove_all(dir);
}
