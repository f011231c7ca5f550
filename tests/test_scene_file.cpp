// Scene files (`nonholo run FILE.json`): a file that spells out sleigh_chain with 3 bodies
// gives that scene's trajectory, a file with a 3-D rigid body (the Suslov problem) the
// trajectory of the model built by hand, and every kind of mistake gets a message naming the
// file, the position and the problem, with a non-zero exit.
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

#include "support/bitwise_equal.hpp"
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
                    {"bodies[0]: unknown key 'mas' (known: heading, inertia, mass, name, position, turn_rate, type, velocity)"});
  expect_file_error(R"({"bodies": [)" + kBody + R"(], "constraints": [{"type": "wheel", "body": 0}]})",
                    {"constraints[0].type: unknown constraint type 'wheel' (known: knife_edge, hitch, body_axis, space_axis, "
                     "rolling_ball, rolling_disk, rod)"});
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

// A NUL byte ended the input for the parser: what followed was ignored, silently (a second
// body after it, a trailing typo). Refused wherever it is, with its line.
TEST(SceneFile, ANulByteIsRefusedWithItsLine) {
  const std::string text = R"({"bodies": [)" + kBody + "]}";
  testing::expect_error([&] { scenarios::parse_scene_text(text + std::string(1, '\0') + "junk", "nul.json"); },
                        "nul.json: line 1 has a NUL byte (byte " + std::to_string(text.size() + 1));
  testing::expect_error(
      [&] { scenarios::parse_scene_text("{\n\"dt\": 0.1,\n" + std::string(1, '\0') + text.substr(1), "nul.json"); },
      "nul.json: line 3 has a NUL byte");
  EXPECT_NO_THROW(scenarios::parse_scene_text(text, "nul.json"));
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
  // Not diagonal: eigenvalues 1e-13 and 1 in a rotated frame. Rounding the rotated entries (of
  // size 1) moves the small eigenvalue by a few eps, 1e-3 of it: the condition number printed is
  // 1e+13 to about 1 % (1e+13 in the portable build, 1.00038e+13 with -march=native's vector code).
  Eigen::Matrix2d rotation;
  rotation << std::cos(0.3), -std::sin(0.3), std::sin(0.3), std::cos(0.3);
  Eigen::Matrix2d m = rotation * Eigen::Vector2d(1e-13, 1.0).asDiagonal() * rotation.transpose();
  m(1, 0) = m(0, 1);
  testing::expect_error([&] { ModelBuilder().add_body({"x", "y"}, m); }, "condition number ");
  try {
    ModelBuilder().add_body({"x", "y"}, m);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    const auto at = what.find("condition number ") + 17;
    EXPECT_NEAR(std::stod(what.substr(at)), 1e13, 1e11) << what;
    EXPECT_NE(what.find(" (above 1e+12)", at), std::string::npos) << what;
  }
  // The test is relative: a well-conditioned block of any scale is accepted.
  m = 1e-200 * rotation * Eigen::Vector2d(1e-6, 1.0).asDiagonal() * rotation.transpose();
  m(1, 0) = m(0, 1);
  EXPECT_EQ(ModelBuilder().add_body({"x", "y"}, m), 0);
}

// --- 3-D rigid bodies (issue 22) --------------------------------------------------------------

std::string example(const std::string& name) { return std::string(NONHOLO_SOURCE_DIR) + "/examples/scenes/" + name; }

// The number after "key=" in a summary line.
double field(const std::string& line, const std::string& key) {
  const auto at = line.find(" " + key + "=");
  if (at == std::string::npos) return std::nan("");
  return std::stod(line.substr(at + key.size() + 2));
}

TEST(SceneFile, SuslovFileIsTheModelBuiltByHand) {
  const auto info = scenarios::load_scene_file(example("suslov.json"));
  EXPECT_EQ(info.default_dt, 0.01);
  EXPECT_EQ(info.default_t_end, 10.0);
  const auto file = info.build(info.defaults());
  ModelBuilder b;
  RigidBody body;
  body.inertia << 1, 0, 0.5, 0, 2, 0.5, 0.5, 0.5, 3;
  body.any_inertia = true;  // the test inertia: its moments break the triangle inequality
  b.add_rigid_body(body);
  b.add_body_axis_constraint({0, Eigen::Vector3d::UnitZ()}, "constraints[0] (body_axis on body 0)");
  const Model model = std::move(b).build();
  Vector q0(4), v0(3);
  q0 << 1, 0, 0, 0;
  v0 << 1, 0.6, 0;
  ASSERT_EQ(file.model.num_configuration(), 4);
  ASSERT_EQ(file.model.num_velocities(), 3);
  EXPECT_EQ(file.model.coordinate_names(), model.coordinate_names());
  EXPECT_EQ(file.model.velocity_names(), model.velocity_names());
  EXPECT_EQ(file.model.row_label(0), model.row_label(0));
  ASSERT_TRUE(file.model.has_rigid_bodies());
  EXPECT_EQ(file.model.rigid_bodies()[0].inertia, model.rigid_bodies()[0].inertia);
  EXPECT_EQ(file.model.rigid_bodies()[0].translation, 0);
  EXPECT_TRUE(testing::bitwise_equal(file.q0, q0));
  EXPECT_TRUE(testing::bitwise_equal(file.v0, v0));
  Workspace wa(file.model), wb(model);
  State a = start_from_velocity(file.model, wa, 0.0, file.q0, file.v0);
  State c = start_from_velocity(model, wb, 0.0, q0, v0);
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(file.model, wa, a, {0.01}), Status::Ok) << wa.message();
    ASSERT_EQ(step(model, wb, c, {0.01}), Status::Ok) << wb.message();
  }
  EXPECT_TRUE(testing::bitwise_equal(a.q, c.q));
  EXPECT_TRUE(testing::bitwise_equal(a.p, c.p));
  EXPECT_TRUE(testing::bitwise_equal(a.lambda, c.lambda));
  EXPECT_GT((a.q - q0).norm(), 0.1) << "the body turned";
}

// The examples run, with the post-momentum energy at round-off where nothing does work, and
// start on the constraints: their velocities satisfy mu(q0) v0 = 0 as written (the Chaplygin
// ball's and the disk's are the rolling velocities), their holonomic gaps vanish.
TEST(SceneFile, RigidBodyExamplesRunFromTheCommandLine) {
  for (const std::string name : {"suslov.json", "chaplygin_ball.json", "rolling_disk.json"}) {
    SCOPED_TRACE(name);
    const auto info = scenarios::load_scene_file(example(name));
    const auto setup = info.build(info.defaults());
    const Model& m = setup.model;
    Vector values(m.num_one_form_values()), mu_v(m.num_one_forms());
    m.one_form_values(setup.q0, values);
    m.mu_times(values.data(), setup.v0.data(), mu_v.data());
    EXPECT_LE(mu_v.lpNorm<Eigen::Infinity>(), 1e-15);
    if (m.num_holonomic() > 0) {
      Vector gap(m.num_holonomic());
      m.gap(setup.q0, gap);
      EXPECT_LE(gap.lpNorm<Eigen::Infinity>(), 1e-15);
    }
    const Cli r = cli({"run", example(name)});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_THAT(r.out, ::testing::HasSubstr("status=ok"));
    if (name == "rolling_disk.json") {
      // Gravity does work; the height row's position corrections (holonomic mode) add O(h^2)
      // work of their own (docs/reference/summary.md: energy_balance_err_max), a one-form height row none.
      EXPECT_LE(field(r.out, "energy_balance_err_max"), 1e-5) << r.out;
      const Cli oneform = cli({"run", example(name), "--hitch", "oneform"});
      ASSERT_EQ(oneform.code, 0) << oneform.err;
      EXPECT_LE(field(oneform.out, "energy_balance_err_max"), 1e-13) << oneform.out;
    } else {
      EXPECT_LE(field(r.out, "energy_post_rel_err_max"), 1e-13) << r.out;
    }
  }
}

// Two balls rolling on the ground joined by a rod, under gravity, one driven by a body torque.
const std::string kBallsAndRod = R"({
  "bodies": [
    {"type": "rigid", "name": "a", "mass": 1, "inertia": [0.4, 0.4, 0.4], "translation": 3,
     "position": [0, 0, 0.5], "angular_velocity": [0, 1, 0]},
    {"type": "rigid", "name": "b", "mass": 2, "inertia": [[0.5, 0.1, 0], [0.1, 0.6, 0], [0, 0, 0.7]], "translation": 3,
     "orientation": {"axis": [0, 1, 1], "angle": 0.3}, "position": [1.2, 1.6, 0.5], "angular_velocity": [0.5, 0, -1]}
  ],
  "constraints": [
    {"type": "rod", "bodies": [1, 0], "length": 2},
    {"type": "rolling_ball", "body": 1, "radius": 0.5},
    {"type": "rolling_ball", "body": 0, "radius": 0.5}
  ],
  "forces": [{"type": "gravity"}, {"type": "body_torque", "body": 1, "amplitude": [0, 0, 0.2], "omega": 2}]
})";

TEST(SceneFile, TwoBallsAndARodRun) {
  const auto info = scenarios::parse_scene_text(kBallsAndRod, "balls.json");
  const auto setup = info.build(info.defaults());
  const Model& m = setup.model;
  ASSERT_EQ(m.num_configuration(), 14);
  ASSERT_EQ(m.num_velocities(), 12);
  EXPECT_EQ(m.coordinate_names()[7], "qw1") << "named by index, not by the file's names";
  // Rows body by body: body 0's ball, then the rod joining it to body 1, then body 1's ball.
  ASSERT_EQ(m.num_one_forms(), 7);
  EXPECT_EQ(m.row_label(0), "constraints[2] (rolling_ball on body 0, x)");
  EXPECT_EQ(m.row_label(2), "constraints[2] (rolling_ball on body 0, height)");
  EXPECT_EQ(m.row_label(3), "constraints[0] (rod of bodies 1 and 0)");
  EXPECT_EQ(m.row_label(6), "constraints[1] (rolling_ball on body 1, height)");
  ASSERT_EQ(m.num_holonomic(), 3);
  Vector gap(3);
  m.gap(setup.q0, gap);
  EXPECT_LE(gap.lpNorm<Eigen::Infinity>(), 1e-15);
  Workspace ws(m);
  State s = start_from_velocity(m, ws, 0.0, setup.q0, setup.v0);
  for (int k = 0; k < 500; ++k) ASSERT_EQ(step(m, ws, s, {0.01}), Status::Ok) << ws.message();
  m.gap(s.q, gap);
  EXPECT_LE(gap.lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_GT((s.q - setup.q0).norm(), 0.1) << "they moved";
  const std::string path = temp_path("balls.json");
  std::ofstream(path) << kBallsAndRod;
  const Cli r = cli({"run", path});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, ::testing::HasSubstr("bodies=2 steps=1000"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("status=ok"));
  std::remove(path.c_str());
}

const std::string kRigid = R"({"type": "rigid", "inertia": [1, 2, 3]})";  // about a fixed point
std::string rigid3(const std::string& position, const std::string& extra = "") {
  return R"({"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 3, "position": )" + position + extra + "}";
}
std::string file(const std::string& bodies, const std::string& rest = "") {
  return R"({"bodies": [)" + bodies + "]" + (rest.empty() ? "" : ", " + rest) + "}";
}

TEST(SceneFile, RigidBodyMistakesNameThePathAndTheProblem) {
  // Bodies.
  expect_file_error(file(R"({"type": "soft", "inertia": 1})"), {"bodies[0].type: unknown body type 'soft' (known: planar, rigid)"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "heading": 0})"),
                    {R"(bodies[0]: key 'heading' belongs to planar bodies; this body is rigid ("type": "rigid"): give its "orientation" instead)"});
  expect_file_error(file(R"({"mass": 1, "inertia": 1, "position": [0, 0], "angular_velocity": [0, 0, 1]})"),
                    {R"(bodies[0]: key 'angular_velocity' belongs to rigid bodies; this body is planar (add "type": "rigid")"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "spin": 1})"),
                    {"bodies[0]: unknown key 'spin' (known: angular_velocity, any_inertia, inertia, mass, name, orientation, position, "
                     "translation, type, velocity)"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": [1, 0, 0, 0.01]})"),
                    {"bodies[0].orientation: the quaternion [w, x, y, z] has norm 1.0000499987500624; give a unit quaternion "
                     "(norm within 1e-6 of 1)"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": [1, 0, 0]})"),
                    {"bodies[0].orientation: expected 4 numbers, got 3 entries"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": "up"})"),
                    {R"(bodies[0].orientation: expected a unit quaternion [w, x, y, z] or {"axis": [x, y, z], "angle": radians}, got string)"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [0, 0, 0], "angle": 1}})"),
                    {"bodies[0].orientation.axis: must not be zero"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [0, 0, 1]}})"),
                    {"bodies[0].orientation.angle: missing (a number is required)"});
  expect_file_error(file(R"({"type": "rigid"})"), {"bodies[0].inertia: missing (3 principal moments"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, -2, 3]})"),
                    {"bodies[0].inertia: rigid body 0: inertia is not positive definite (principal moments"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [[1, 0, 0], [0.5, 2, 0], [0, 0, 3]]})"),
                    {"bodies[0].inertia: rigid body 0: inertia is not symmetric: I(1, 0) = 0.5 but I(0, 1) = 0"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 2]})"),
                    {"bodies[0].inertia: expected 3 principal moments [I1, I2, I3] or a 3x3 array [[...], [...], [...]], got 2 entries"});
  expect_file_error(file(R"({"type": "rigid", "inertia": 1})"), {"bodies[0].inertia: expected 3 principal moments", "got number"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [[1, 0, 0], [0, 1], [0, 0, 1]]})"),
                    {"bodies[0].inertia[1]: expected a row of 3 numbers (the inertia is a 3x3 array), got 2 entries"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [[1, 0, 0], [0, 1, "x"], [0, 0, 1]]})"),
                    {"bodies[0].inertia[1][2]: expected a number, got string"});
  // The inertia is fine; with the mass the block is not (the path is the body's).
  expect_file_error(file(R"({"type": "rigid", "mass": 1e13, "inertia": [1, 1, 1], "translation": 2, "position": [0, 0]})"),
                    {"bodies[0]: rigid body 0: mass block is too ill-conditioned"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 1, 1], "translation": 1})"),
                    {"bodies[0].translation: must be 0 (a fixed point), 2 (the centre moves in a horizontal plane) or 3 (free), got 1"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 1, 1], "translation": "free"})"),
                    {"bodies[0].translation: expected 0, 2 or 3, got string"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 1, 1], "translation": 3, "position": [0, 0, 1]})"),
                    {"bodies[0].mass: missing (a number is required)"});
  expect_file_error(file(R"({"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 3})"),
                    {"bodies[0].position: missing (3 numbers are required)"});
  expect_file_error(file(R"({"type": "rigid", "inertia": [1, 1, 1], "position": [0, 0]})"),
                    {R"(bodies[0].position: the body's centre is fixed (translation 0); give "translation": 2 or 3 to move it)"});
  // Constraints: the elements' own checks, with the path.
  const std::string flat2 = R"({"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 2, "position": [0, 0]})";
  const std::string planar = R"({"mass": 1, "inertia": 1, "position": [0, 0]})";
  expect_file_error(file(flat2, R"("constraints": [{"type": "rolling_disk", "body": 0, "radius": 1}])"),
                    {"constraints[0]: rolling disk: body 0 has translation 2; a rolling disk's centre rises and falls as it "
                     "tilts (translation 3)"});
  expect_file_error(file(planar, R"("constraints": [{"type": "rolling_ball", "body": 0, "radius": 1}])"),
                    {"constraints[0]: rolling ball: body 0 is not a 3-D rigid body"});
  expect_file_error(file(kRigid, R"("constraints": [{"type": "knife_edge", "body": 0}])"),
                    {"constraints[0]: knife edge: body 0 is a 3-D rigid body; this element acts on planar bodies"});
  expect_file_error(file(kRigid, R"("constraints": [{"type": "rolling_ball", "body": 2, "radius": 1}])"),
                    {"constraints[0].body: body 2 does not exist (the file has 1 bodies, 0 to 0)"});
  expect_file_error(file(kRigid + "," + kRigid, R"("constraints": [{"type": "rod", "bodies": [0, 5], "length": 1}])"),
                    {"constraints[0].bodies[1]: body 5 does not exist (the file has 2 bodies, 0 to 1)"});
  expect_file_error(file(kRigid, R"("constraints": [{"type": "rolling_ball", "body": 0, "radius": 0}])"),
                    {"constraints[0].radius: must be positive, got 0"});
  expect_file_error(file(kRigid, R"("constraints": [{"type": "body_axis", "body": 0}])"),
                    {"constraints[0].axis: missing (3 numbers are required)"});
  expect_file_error(file(kRigid, R"("constraints": [{"type": "body_axis", "body": 0, "axis": [0, 0, 0]}])"),
                    {"constraints[0]: body-axis constraint: axis (0 0 0) must be finite and nonzero"});
  expect_file_error(file(flat2 + "," + rigid3("[1, 0, 1]"), R"("constraints": [{"type": "rod", "bodies": [0, 1], "length": 1}])"),
                    {"constraints[0]: rod: body 0's centre moves in 2-D, body 1's in 3-D"});
  // Holonomic constraints must hold at the start.
  expect_file_error(file(rigid3("[0, 0, 1]") + "," + rigid3("[3, 0, 1]"), R"("constraints": [{"type": "rod", "bodies": [0, 1], "length": 2}])"),
                    {"constraints[0]: the rod is not at its length at the start: the centres of bodies 0 and 1 are 3 apart, "
                     "the rod is 2 long (place body 1 at distance 2 from body 0)"});
  expect_file_error(file(planar + "," + flat2, R"("constraints": [{"type": "rod", "bodies": [1, 0], "length": 2}])"),
                    {"constraints[0]: the rod is not at its length at the start: the centres of bodies 1 and 0 are 0 apart"});
  expect_file_error(file(rigid3("[0, 0, 2]"), R"("constraints": [{"type": "rolling_ball", "body": 0, "radius": 1}])"),
                    {"constraints[0]: the ball is not on the ground at the start: its centre is at height 2, its radius is 1 "
                     "(set bodies[0].position[2] to 1)"});
  expect_file_error(file(rigid3("[0, 0, 0.5]", R"(, "orientation": {"axis": [1, 0, 0], "angle": 0.5235987755982988})"),
                         R"("constraints": [{"type": "rolling_disk", "body": 0, "radius": 2}])"),
                    {"constraints[0]: the disk is not on the ground at the start: its centre is at height 0.5",
                     "touches the ground with its centre at r sqrt(1 - n_z^2) = 1 (set bodies[0].position[2] to "});
  expect_file_error(file(rigid3("[0, 0, 0]"), R"("constraints": [{"type": "rolling_disk", "body": 0, "radius": 1}])"),
                    {"constraints[0]: the disk lies flat at the start (its axis R e3 is vertical"});
  // Forces.
  expect_file_error(file(kRigid, R"("forces": [{"type": "wind"}])"),
                    {"forces[0].type: unknown force type 'wind' (known: thrust, torque, gravity, body_torque, body_force)"});
  expect_file_error(file(kRigid, R"("forces": [{"type": "gravity"}])"),
                    {R"(forces[0]: gravity acts on rigid bodies that move freely in 3-D ("translation": 3), and the file has none)"});
  expect_file_error(file(rigid3("[0, 0, 0]"), R"("forces": [{"type": "gravity"}, {"type": "gravity", "g": 1}])"),
                    {"forces[1]: gravity is given twice (first in forces[0])"});
  expect_file_error(file(planar, R"("forces": [{"type": "body_torque", "body": 0, "value": [0, 0, 1]}])"),
                    {"forces[0]: body torque: body 0 is not a 3-D rigid body"});
  expect_file_error(file(kRigid, R"("forces": [{"type": "body_force", "body": 0, "value": [1, 0, 0]}])"),
                    {"forces[0]: body force on body 0: its centre is fixed (translation 0)"});
  expect_file_error(file(kRigid, R"("forces": [{"type": "body_torque", "body": 0, "value": 1}])"),
                    {"forces[0].value: expected 3 numbers, got number"});
  expect_file_error(file(kRigid, R"("forces": [{"type": "thrust", "body": 0, "value": 1}])"),
                    {"forces[0]: thrust: body 0 is a 3-D rigid body"});
  expect_file_error(file(kRigid + "," + kRigid, R"("couplings": [{"type": "torsional_spring", "bodies": [0, 1], "stiffness": 1}])"),
                    {"couplings[0]: torsional spring: body 0 is a 3-D rigid body"});
}

TEST(SceneFile, RigidBodyOrientationsAndDefaults) {
  // A quaternion within 1e-6 of unit norm is normalised; axis and angle give the rotation
  // (any nonzero scale of the axis); velocities default to rest.
  const auto info = scenarios::parse_scene_text(
      file(R"({"type": "rigid", "inertia": [1, 2, 3], "orientation": [1, 0, 0, 1e-4]},
              {"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [0, 0, 1e-300], "angle": 1}},
              {"type": "rigid", "mass": 2, "inertia": [1, 2, 3], "translation": 2, "position": [1, 2]})"),
      "orientations.json");
  const auto setup = info.build(info.defaults());
  ASSERT_EQ(setup.q0.size(), 4 + 4 + 6);
  EXPECT_NEAR(setup.q0.segment<4>(0).norm(), 1.0, 1e-15);
  EXPECT_NEAR(setup.q0[3], 1e-4, 1e-12);
  EXPECT_NEAR(setup.q0[4], std::cos(0.5), 1e-16);
  EXPECT_NEAR(setup.q0[7], std::sin(0.5), 1e-16);
  EXPECT_TRUE(setup.q0.tail<6>() == (Vector(6) << 1, 0, 0, 0, 1, 2).finished()) << setup.q0.transpose();
  EXPECT_TRUE(setup.v0 == Vector::Zero(11)) << setup.v0.transpose();
  EXPECT_EQ(setup.model.rigid_bodies()[0].mass, 1.0) << "mass defaults to 1 about a fixed point";
  EXPECT_EQ(setup.model.rigid_bodies()[2].mass, 2.0);
  // A 3x3 inertia nests 5 levels deep: within the limit, which the message states.
  testing::expect_error([] { scenarios::parse_scene_text(std::string(65, '['), "deep.json"); },
                        "nested deeper than 64 levels (a scene file needs 5)");
}

TEST(SceneFile, RigidBodyRowsAreLabelledWithTheirElement) {
  // Two identical body axes: dependent one-forms at the start, named by the second's label.
  const std::string path = temp_path("axes.json");
  std::ofstream(path) << file(kRigid, R"("constraints": [{"type": "body_axis", "body": 0, "axis": [0, 0, 1]},
                                                         {"type": "body_axis", "body": 0, "axis": [0, 0, 2]}])");
  const Cli r = cli({"run", path, "--t-end", "0.1"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, ::testing::HasSubstr("dependent"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("constraints[1] (body_axis on body 0)"));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace nonholo
