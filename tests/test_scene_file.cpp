// Scene files (`nonholo run FILE.json`): a file that spells out sleigh_chain with 3 bodies
// gives that scene's trajectory, and every kind of mistake gets a message naming the file,
// the position and the problem, with a non-zero exit.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "support/expect_error.hpp"
#include "support/run_cli.hpp"

namespace nonholo {
namespace {

const std::string kExample = std::string(NONHOLO_SOURCE_DIR) + "/examples/scenes/three_sleigh_chain.json";

TEST(SceneFile, SpellsOutTheSleighChain) {
  const auto from_file = scenarios::load_scene_file(kExample);
  EXPECT_EQ(from_file.default_dt, 0.01);
  const auto file_setup = from_file.build(from_file.defaults());
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto p = info.defaults();
  p.set("bodies", 3);
  const auto chain = info.build(p);
  ASSERT_EQ(file_setup.model.num_coordinates(), 9);
  EXPECT_EQ(file_setup.model.coordinate_names(), chain.model.coordinate_names());
  EXPECT_EQ(file_setup.model.num_holonomic(), 4);
  Workspace wa(file_setup.model), wb(chain.model);
  State a = start_from_velocity(file_setup.model, wa, 0.0, file_setup.q0, file_setup.v0);
  State b = start_from_velocity(chain.model, wb, 0.0, chain.q0, chain.v0);
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(file_setup.model, wa, a, {0.01}), Status::Ok) << wa.message();
    ASSERT_EQ(step(chain.model, wb, b, {0.01}), Status::Ok);
  }
  // Rows in another order (knife edges first): the same dynamics up to round-off.
  EXPECT_LE((a.q - b.q).lpNorm<Eigen::Infinity>(), 1e-12);
}

using Cli = testing::CliResult;

Cli cli(std::vector<std::string> args) { return testing::run_cli(std::move(args)); }

// Writes `text` to a temporary .json file and runs it; expects exit 1 and every fragment.
void expect_file_error(const std::string& text, const std::vector<std::string>& fragments) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("nonholo_scene_" + std::to_string(::getpid()) + ".json")).string();
  std::ofstream(path) << text;
  const Cli r = cli({"run", path, "--t-end", "0.1"});
  EXPECT_EQ(r.code, 1) << text;
  EXPECT_THAT(r.err, ::testing::HasSubstr(path + ": ")) << "names the file";
  for (const auto& f : fragments) EXPECT_THAT(r.err, ::testing::HasSubstr(f)) << text;
  std::remove(path.c_str());
}

const std::string kBody = R"({"mass": 1, "inertia": 1, "position": [0, 0]})";

TEST(SceneFile, MistakesNameTheFileThePositionAndTheProblem) {
  expect_file_error("{\n  \"bodies\": [\n    {\"mass\": 1,, }\n  ]\n}", {"line 3, column 16: syntax error"});
  expect_file_error(R"({"bodies": []})", {"bodies: missing (an array of at least one body is required)"});
  expect_file_error(R"({"bodies": [{"inertia": 1, "position": [0, 0]}]})", {"bodies[0].mass: missing (a number is required)"});
  expect_file_error(R"({"bodies": [{"mass": -1, "inertia": 1, "position": [0, 0]}]})", {"bodies[0].mass: must be positive, got -1"});
  expect_file_error(R"({"bodies": [{"mass": "heavy", "inertia": 1, "position": [0, 0]}]})",
                    {"bodies[0].mass: expected a number, got string"});
  expect_file_error(R"({"bodies": [{"mass": 1, "inertia": 1, "position": [0, 0, 0]}]})",
                    {"bodies[0].position: expected 2 numbers, got 3 entries"});
  expect_file_error(R"({"bodies": [{"mass": 1, "inertia": 1, "position": [0, 1e999]}]})",
                    {"line 1, column 55: the number 1e999 is not a finite double"});
  expect_file_error(R"({"bodies": [{"mas": 1, "inertia": 1, "position": [0, 0]}]})",
                    {"bodies[0]: unknown key 'mas' (known: heading, inertia, mass, name, position, turn_rate, velocity)"});
  expect_file_error(R"({"bodies": [)" + kBody + R"(], "constraints": [{"type": "wheel", "body": 0}]})",
                    {"constraints[0].type: unknown constraint type 'wheel' (known: knife_edge, hitch)"});
  expect_file_error(R"({"bodies": [)" + kBody + R"(], "constraints": [{"type": "knife_edge", "body": 3}]})",
                    {"constraints[0].body: body 3 does not exist (the file has 1 bodies, 0 to 0)"});
  expect_file_error(R"({"bodies": [)" + kBody + "," + kBody + R"(], "couplings": [{"type": "rope", "bodies": [0, 1]}]})",
                    {"couplings[0].type: unknown coupling type 'rope' (known: torsional_spring)"});
  expect_file_error(R"({"bodies": [)" + kBody + "," + kBody + R"(], "couplings": [{"type": "torsional_spring", "bodies": [0, 0], "stiffness": 1}]})",
                    {"couplings[0].bodies: a body cannot be joined to itself"});
  expect_file_error(R"({"bodies": [)" + kBody + "," + kBody + R"(], "constraints": [{"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5}]})",
                    {"the hitch is open at the start: its two points are 1 apart"});
  expect_file_error(R"({"bodies": [)" + kBody + R"(], "forces": [{"type": "thrust"}]})", {"forces[0].body: missing"});
  expect_file_error(R"({"bodies": [)" + kBody + R"(], "dt": 0})", {"dt: must be positive"});
  const Cli missing = cli({"run", "/nonexistent/scene.json"});
  EXPECT_EQ(missing.code, 1);
  EXPECT_THAT(missing.err, ::testing::HasSubstr("/nonexistent/scene.json: cannot be read"));
  const Cli set = cli({"run", kExample, "--set", "m=2"});
  EXPECT_EQ(set.code, 1);
  EXPECT_THAT(set.err, ::testing::HasSubstr("--set does not apply to a scene file"));
}

TEST(SceneFile, RunsFromTheCommandLine) {
  const Cli r = cli({"run", kExample, "--t-end", "1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("bodies=3 steps=100"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("status=ok"));
}

}  // namespace
}  // namespace nonholo
