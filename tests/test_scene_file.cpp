// Scene files (`nonholo run FILE.json`): a file that spells out sleigh_chain with 3 bodies
// gives that scene's trajectory, and every kind of mistake gets a message naming the file,
// the position and the problem, with a non-zero exit.
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

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

// Issue 11: input that used to crash, hang or be accepted silently.

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_" + std::to_string(::getpid()) + "_" + name)).string();
}

// Expects load_scene_file(path) and, for *.json, `nonholo run path` to refuse with every fragment.
void expect_refused(const std::string& path, const std::vector<std::string>& fragments) {
  for (const auto& f : fragments)
    testing::expect_error([&] { scenarios::load_scene_file(path); }, path + ": " + f);
  if (!scenarios::is_scene_file(path)) return;
  const Cli r = cli({"run", path});
  EXPECT_EQ(r.code, 1) << path;
  for (const auto& f : fragments) EXPECT_THAT(r.err, ::testing::HasSubstr(f)) << path;
}

TEST(SceneFile, DeepNestingIsRefusedWithoutCrashing) {
  testing::expect_error([] { scenarios::parse_scene_text(std::string(100000, '['), "deep.json"); },
                        "deep.json: line 1, column 65: arrays and objects nested deeper than 64 levels");
  // Valid JSON: without the limit, copying the constraints would recurse a million deep.
  const std::size_t depth = 1000000;
  const std::string text = R"({"bodies": [)" + kBody + R"(], "constraints": )" + std::string(depth, '[') +
                           std::string(depth, ']') + "}";
  testing::expect_error([&] { scenarios::parse_scene_text(text, "deep.json"); }, "nested deeper than 64 levels");
  // Brackets inside strings do not count.
  const auto info = scenarios::parse_scene_text(
      R"({"description": ")" + std::string(100, '[') + R"(", "bodies": [)" + kBody + "]}", "brackets.json");
  EXPECT_EQ(info.build(info.defaults()).model.num_bodies(), 1);
}

TEST(SceneFile, DuplicateKeysAreRefusedWithTheirPath) {
  testing::expect_error(
      [] { scenarios::parse_scene_text(R"({"bodies": [)" + kBody + R"(, {"mass": 1, "mass": 2}]})", "dup.json"); },
      "dup.json: bodies[1]: duplicate key 'mass'");
  testing::expect_error([] { scenarios::parse_scene_text(R"({"dt": 0.1, "bodies": [], "dt": 0.2})", "dup.json"); },
                        "dup.json: (top level): duplicate key 'dt'");
  testing::expect_error(
      [] {
        scenarios::parse_scene_text(R"({"bodies": [{"position": [0, 0], "x": {"a": 1, "a": 1}}]})", "dup.json");
      },
      "dup.json: bodies[0].x: duplicate key 'a'");
  // Control characters in keys are shown, not sent to the terminal.
  testing::expect_error([] { scenarios::parse_scene_text(R"({"\u0007": 1, "\u0007": 2})", "dup.json"); },
                        R"(dup.json: (top level): duplicate key '\x07')");
}

TEST(SceneFile, OnlyRegularFilesAreRead) {
  const std::string dir = temp_path("dir.json");
  std::filesystem::create_directory(dir);
  expect_refused(dir, {"is a directory; a scene file must be a regular file"});
  std::filesystem::remove(dir);
  expect_refused("/dev/zero", {"is a character device; a scene file must be a regular file"});
  const std::string zero = temp_path("zero.json");  // the command line takes *.json only
  std::filesystem::create_symlink("/dev/zero", zero);
  expect_refused(zero, {"is a character device"});
  std::filesystem::remove(zero);
  const std::string fifo = temp_path("fifo.json");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_refused(fifo, {"is a FIFO (named pipe); a scene file must be a regular file"});
  std::filesystem::remove(fifo);
}

TEST(SceneFile, FilesOverTheSizeLimitAreRefused) {
  const std::string big = temp_path("big.json");
  std::ofstream(big).close();
  std::filesystem::resize_file(big, scenarios::kMaxSceneFileBytes + 1);  // sparse: no disk used
  expect_refused(big, {"is 67108865 bytes; a scene file may be at most 67108864 bytes (64 MiB)"});
  std::filesystem::remove(big);
}

TEST(SceneFile, ProblemsFoundAfterParsingNameTheElement) {
  const std::string two = kBody + R"(, {"mass": 1, "inertia": 1, "position": [-1, 0]})";
  const std::string hitch = R"({"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5})";
  // Two identical knife edges on body 1: dependent one-forms at the start.
  const std::string path = temp_path("knives.json");
  std::ofstream(path) << R"({"bodies": [)" + two + R"(], "constraints": [{"type": "knife_edge", "body": 0}, )" +
                             hitch + R"(, {"type": "knife_edge", "body": 1}, {"type": "knife_edge", "body": 1}]})";
  const Cli r = cli({"run", path, "--t-end", "0.1"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, ::testing::HasSubstr("dependent"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("constraints[3] (knife_edge on body 1)"));
  std::remove(path.c_str());
  // An open hitch and an ill-conditioned body name their element too.
  const std::string open = R"({"bodies": [)" + kBody + "," + kBody + R"(], "constraints": [{"type": "knife_edge", "body": 0}, )" +
                           hitch + "]}";
  testing::expect_error([&] { scenarios::parse_scene_text(open, "open.json"); },
                        "open.json: constraints[1]: the hitch is open at the start");
  const auto ill = scenarios::parse_scene_text(R"({"bodies": [)" + kBody +
                                                   R"(, {"mass": 1e17, "inertia": 1, "position": [1, 0]}]})",
                                               "ill.json");
  testing::expect_error([&] { ill.build(ill.defaults()); }, "ill.json: bodies[1]: body 1 (x1, y1, theta1): mass block is too ill-conditioned");
}

TEST(SceneFile, IllConditionedMassBlocksAreCalledSo) {
  // diag(1, 1e17) is positive definite in exact arithmetic, but not usable in doubles.
  testing::expect_error([] { ModelBuilder().add_body({"x", "y"}, Eigen::Vector2d(1.0, 1e17).asDiagonal().toDenseMatrix()); },
                        "body 0 (x, y): mass block is too ill-conditioned for double precision: its eigenvalues run "
                        "from 1 to 1e+17, condition number 1e+17 (above 1e+12)");
  // Not diagonal: eigenvalues 1e-13 and 1 in a rotated frame.
  Eigen::Matrix2d rotation;
  rotation << std::cos(0.3), -std::sin(0.3), std::sin(0.3), std::cos(0.3);
  Eigen::Matrix2d m = rotation * Eigen::Vector2d(1e-13, 1.0).asDiagonal() * rotation.transpose();
  m(1, 0) = m(0, 1);
  testing::expect_error([&] { ModelBuilder().add_body({"x", "y"}, m); }, "condition number 1e+13 (above 1e+12)");
  // The test is relative: a well-conditioned block of any scale is accepted.
  m = 1e-200 * rotation * Eigen::Vector2d(1e-6, 1.0).asDiagonal() * rotation.transpose();
  m(1, 0) = m(0, 1);
  EXPECT_EQ(ModelBuilder().add_body({"x", "y"}, m), 0);
}

}  // namespace
}  // namespace nonholo
