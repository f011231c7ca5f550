// A run's output read back in C++ (results.hpp): the frames the run produced (a sink keeps
// them in memory), bit for bit, from CSV and HDF5; HDF5's p, gap and summary; the refusals.
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/results.hpp>
#include <nonholo/scenarios/run.hpp>

#include "support/bitwise_equal.hpp"
#include "support/run_cli.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace nonholo::scenarios {
namespace {

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_results_" + std::to_string(::getpid()) + "_" + name)).string();
}

// The frames as the run hands them out.
class Frames final : public FrameSink {
 public:
  void begin(const std::vector<std::string>& names) override { coordinates = names; }
  void frame(double time, ConstVecRef q_now, ConstVecRef p_now, const Diagnostics& d) override {
    t.push_back(time);
    q.emplace_back(q_now);
    p.emplace_back(p_now);
    diagnostics.push_back(d);
  }
  std::vector<std::string> coordinates;
  std::vector<double> t;
  std::vector<Vector> q, p;
  std::vector<Diagnostics> diagnostics;
};

bool same(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(Results, ARunsFileReadsBackBitForBit) {
  for (const char* ext : {"csv", "h5"}) {
    SCOPED_TRACE(ext);
    const std::string path = temp(std::string("run.") + ext);
    RunConfig config = parse_run_arguments({"wheeled_train", "--set", "bodies=5", "--t-end", "1", "--every", "7"});
    config.csv_path = path;
    Frames frames;
    config.sink = &frames;
    const RunSummary summary = run_scene(config);
    ASSERT_EQ(summary.status, Status::Ok);
    const RunData back = load_run(path);
    EXPECT_EQ(back.coordinates, frames.coordinates);
    ASSERT_EQ(back.t.size(), static_cast<Eigen::Index>(frames.t.size()));
    for (std::size_t k = 0; k < frames.t.size(); ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      EXPECT_TRUE(same(back.t[i], frames.t[k]));
      EXPECT_TRUE(testing::bitwise_equal(Vector(back.q.row(i).transpose()), frames.q[k])) << "frame " << k;
      EXPECT_TRUE(same(back.energy[i], frames.diagnostics[k].energy));
      EXPECT_TRUE(same(back.energy_post[i], frames.diagnostics[k].energy_post));
      EXPECT_TRUE(same(back.residual[i], frames.diagnostics[k].residual));
      if (std::string(ext) == "h5") {
        EXPECT_TRUE(testing::bitwise_equal(Vector(back.p.row(i).transpose()), frames.p[k])) << "frame " << k;
        EXPECT_TRUE(same(back.gap[i], frames.diagnostics[k].gap));
      }
    }
    if (std::string(ext) == "h5") {
      EXPECT_EQ(back.summary.at("steps"), 100.0);
      EXPECT_TRUE(same(back.summary.at("energy_balance_err_max"), summary.energy_balance_err_max));
      EXPECT_EQ(back.summary_text.at("status"), "ok");
    } else {
      EXPECT_EQ(back.p.size(), 0);
      EXPECT_TRUE(back.summary.empty());
    }
    std::filesystem::remove(path);
  }
}

TEST(Results, RefusesWhatIsNotARunsOutput) {
  const std::string batch = temp("batch.h5"), checkpoint = temp("ck.h5"), other = temp("x.txt");
  ASSERT_EQ(testing::run_cli({"batch", "sleigh", "--count", "2", "--t-end", "0.1", "--out", batch}).code, 0);
  ASSERT_EQ(testing::run_cli({"run", "sleigh", "--t-end", "0.1", "--checkpoint", checkpoint}).code, 0);
  auto refused = [](const std::string& path, const std::string& why) {
    try {
      load_run(path);
      ADD_FAILURE() << "accepted " << path;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(why));
    }
  };
  refused(batch, "is a 'nonholo batch' file, not a run's output");
  refused(checkpoint, "is a 'nonholo checkpoint' file, not a run's output");
  refused(other, "expected a run's .csv, .h5 or .hdf5 output");
  refused(temp("missing.csv"), "cannot read");
  for (const auto& f : {batch, checkpoint}) std::filesystem::remove(f);
}

}  // namespace
}  // namespace nonholo::scenarios
