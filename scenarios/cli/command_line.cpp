// The `nonholo` command line (<nonholo/scenarios/command_line.hpp>): run, batch, wp, list and
// their options parsed with CLI11 into RunConfig and BatchConfig, the summary printed, exit codes.
#include <nonholo/scenarios/command_line.hpp>

#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/interrupt.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/scenarios/work_precision.hpp>

#include <nonholo/build_config.hpp>
#include <nonholo/version.hpp>

#include "fnv1a.hpp"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <iterator>
#include <thread>

namespace nonholo::scenarios {

// The shell's convention for a process ended by SIGINT (128 + 2).
constexpr int kInterruptedExit = 130;
constexpr int kInaccurateExit = 3;  // the run finished, its results are written, but not to --accuracy
namespace {

constexpr const char* kRunHelp = "integrate one scene and print a summary line";
constexpr const char* kBatchHelp = "integrate many trajectories of one scene in parallel";
// Where --help sends a reader next (the docs live in the repository).
constexpr const char* kHelpFooter =
    "Scenes and their parameters: nonholo list. Scene files (FILE.json): docs/reference/scene-files.md.\n"
    "Output files: CSV, or HDF5 for .h5/.hdf5. Summary keys and exit codes: docs/reference/summary.md,\n"
    "docs/reference/statuses.md.";

// The options `run` and `batch` share, with their raw strings for the enums.
struct RunOptions {
  RunConfig config;
  std::string backend = "auto", hitch = "holonomic";
};

void add_run_options(CLI::App* cmd, RunOptions& o) {
  cmd->add_option("scene", o.config.scene,
                  "scene name (particle, sleigh, sleigh_contact, snakeboard, sleigh_chain, wheeled_train, suslov, "
                  "veselova, chaplygin_ball, ball_chain, rolling_disk; `nonholo list` shows their parameters) or a "
                  "scene file FILE.json (docs/reference/scene-files.md)");
  cmd->add_option("--dt", o.config.dt, "time step (default: the scene's)");
  cmd->add_option("--t-end", o.config.t_end, "final time (default: the scene's)");
  cmd->add_option("--set", o.config.assignments, "set a scene parameter, NAME=VALUE (repeatable)")
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--backend", o.backend,
                  "factorisation of C: auto, block-diagonal, dense, banded, cholmod-natural, cholmod-amd");
  cmd->add_option("--hitch", o.hitch, "hitches: holonomic (position level, default) or oneform");
  cmd->add_option("--method", o.config.method,
                  "reflection (default), dla-midpoint, dla-left, rk4, arkode-dp5 (Dormand-Prince 5(4)), "
                  "arkode-verner (Verner 6(5)), arkode-fehlberg8 (Fehlberg 8(7)) (the last four integrate the "
                  "index-reduced equations; --dt is then RK4's step or ARKODE's output interval)");
  cmd->add_flag("--project", o.config.project,
                "rk4 and arkode-*: project onto the constraints (and hitches) after every step");
  cmd->add_option("--tol", o.config.tol, "arkode-*: relative and absolute tolerance (default 1e-8); reflection: adaptive steps (of --order 2, 4, 6 or 8) aiming at this error in q at --t-end (--dt is then the output interval)");
  cmd->add_option("--restart", o.config.restart,
                  "the period-2 mode: auto (default: energy-exact restarts of the multipliers when the "
                  "measured parasitic amplitude exceeds --restart-tol), K (every K steps) or 0 (never: "
                  "the paper's plain method)");
  cmd->add_option("--restart-tol", o.config.restart_tol,
                  "--restart auto: restart when the parasitic amplitude exceeds this (default max(min(dt^3, 1e-3), 64 eps))");
  cmd->add_option("--monitor-every", o.config.monitor_every,
                  "measure the parasitic amplitude every K steps (default 8; 0: never, not with auto)");
  cmd->add_option("--order", o.config.order,
                  "reflection: 2 (default), or 4, 6 and 8 by composing plain steps; --dt is then the "
                  "composed step (12 plain steps for order 4, 20 for order 6, 34 for order 8)");
  cmd->add_option("--composition", o.config.composition, composition_choices());
  cmd->add_option("--rotation", o.config.rotation,
                  "reflection, scenes with 3-D rigid bodies: the rotation's discrete Lagrangian, "
                  "moser-veselov (default: exact energy for any inertia), moser-veselov-f (smaller error) "
                  "or exponential (RATTLie_nonhol's: energy not exact for non-isotropic bodies)");
  cmd->add_flag("--error-estimate", o.config.error_estimate,
                "integrate a companion at dt/2 (ARKODE: tol/100) in the same run and report "
                "error_estimate, the max difference in q over the output times (Richardson-scaled)");
  cmd->add_option("--accuracy", o.config.accuracy,
                  "reflection: end with status=inaccurate (exit 3, results kept) when the estimated error "
                  "in q exceeds this fraction of the motion's extent (default 0.1; 0: no check)");
  cmd->add_option("--accuracy-check", o.config.accuracy_check,
                  "how the accuracy check estimates the error: companion (a second run at 2 dt, adaptive "
                  "steps at 10 tol, alongside: sees errors that grow; half the run's cost again), sampled "
                  "(sampled step doubling: a few per cent, blind to growth) or auto (default: the companion "
                  "up to 300000 velocities, sampled above)");
  cmd->add_flag_function(
      "--quiet", [&o](std::int64_t) { o.config.verbosity = 0; },
      "nothing on standard error but errors: no progress bar, warnings or notes (the summary line still lists "
      "the warnings' kinds)");
  cmd->add_flag_function(
      "--verbose", [&o](std::int64_t) { o.config.verbosity = 2; },
      "also where standard error is no terminal (a log): each set-up phase and the progress every 10 s as "
      "lines; each warning on its own line with its kind");
}

// A batch keeps one row of results per trajectory until it ends: refuse a --count whose rows
// alone exceed the machine's memory (check_batch_memory: std::bad_alloc otherwise), and more
// threads than can run (tens of thousands make the OpenMP runtime fail or crash).
void check_batch_size(const CLI::App* cmd, const BatchConfig& batch) {
  check_batch_memory(batch);
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int max_threads = std::max(256, 8 * cores);
  if (cmd->count("--threads") && batch.threads > max_threads)
    throw std::invalid_argument("--threads " + std::to_string(batch.threads) + ": at most " +
                                std::to_string(max_threads) + " on this machine (8 per hardware thread, of which it has " +
                                std::to_string(cores) + ", and at least 256): more cannot run at once");
}

// Checks that need to know which options were given; fills the enums.
void finish_run_options(const CLI::App* cmd, RunOptions& o) {
  RunConfig& run = o.config;
  if (run.scene.empty() && run.resume_path.empty())
    throw std::invalid_argument("scene is required: a scene name, a scene file FILE.json (or --resume FILE.h5)");
  if (cmd->count("--dt") && !(run.dt > 0.0))
    throw std::invalid_argument("--dt " + std::to_string(run.dt) + ": the step must be positive");
  if (cmd->count("--quiet") && cmd->count("--verbose"))
    throw std::invalid_argument("--quiet and --verbose: give one of them");
  if (run.method != "reflection") {
    for (const char* option :
         {"--hitch", "--restart", "--restart-tol", "--monitor-every", "--order", "--composition", "--rotation"})
      if (cmd->count(option)) throw std::invalid_argument(std::string(option) + " applies to the reflection method only");
  } else {
    run.adaptive = cmd->count("--tol") > 0;
  }
  if (cmd->count("--tol") && (run.method == "rk4" || run.method.rfind("dla", 0) == 0))
    throw std::invalid_argument("--tol applies to the reflection method (adaptive steps) and to arkode-dp5, "
                                "arkode-verner and arkode-fehlberg8");
  if (cmd->count("--restart-tol") && !(run.restart_tol > 0.0))
    throw std::invalid_argument("--restart-tol " + std::to_string(run.restart_tol) + ": must be positive");
  if (cmd->count("--restart-tol") && run.restart != "auto")
    throw std::invalid_argument("--restart-tol applies to --restart auto");
  if (cmd->count("--monitor-every") && run.monitor_every < 0)
    throw std::invalid_argument("--monitor-every " + std::to_string(run.monitor_every) +
                                ": must be 0 (never) or positive");
  if (run.restart == "auto" && run.monitor_every == 0)
    throw std::invalid_argument("--monitor-every 0 turns off the measurement that --restart auto needs");
  try {
    RestartOptions check;
    set_restart(check, run.restart);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--") + e.what());
  }
  if (cmd->count("--t-end") && !(run.t_end >= 0.0))
    throw std::invalid_argument("--t-end " + std::to_string(run.t_end) + ": must be non-negative");
  try {
    rotation_from_string(run.rotation);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--rotation: ") + e.what());
  }
  run.backend = sparse::backend_from_string(o.backend);
  run.hitch = hitch_mode_from_string(o.hitch);
}

// One line to a stream in one write: under mpirun the ranks' stderr (unbuffered) would otherwise
// interleave piece by piece ("nonholo nonholo batch: ..." when two ranks fail at once).
void say(std::ostream& os, const std::string& line) { os << line + "\n" << std::flush; }

// A run's warnings on standard error: none with --quiet, one line of them all by default, one line
// each with its kind with --verbose.
void warn(std::ostream& os, const std::string& who, const RunSummary& s, int verbosity) {
  if (verbosity <= 0 || s.warnings.empty()) return;
  if (verbosity == 1) return say(os, who + ": warning: " + s.warning);
  for (const RunWarning& w : s.warnings) say(os, who + ": warning (" + to_string(w.kind) + "): " + w.text);
}

// "nonholo run sleigh --dt 0.1": the words as given, quoted where a shell would need it.
std::string command_of(const std::string& command, const std::vector<std::string>& args) {
  std::string line = command.empty() ? "nonholo" : "nonholo " + command;
  for (const auto& a : args) {
    const bool plain = !a.empty() && a.find_first_of(" \t'\"\\$`") == std::string::npos;
    line += " " + (plain ? a : "'" + a + "'");
  }
  return line;
}

bool is_checkpoint_path(const std::string& path) {
  auto ends = [&](const char* e, std::size_t n) { return path.size() > n && path.compare(path.size() - n, n, e) == 0; };
  return ends(".h5", 3) || ends(".hdf5", 5);
}

// "--checkpoint-every": N steps, or Ns seconds.
void set_checkpoint_every(RunConfig& run, const std::string& text) {
  const bool seconds = !text.empty() && text.back() == 's';
  const std::string number = seconds ? text.substr(0, text.size() - 1) : text;
  char* end = nullptr;
  const double value = std::strtod(number.c_str(), &end);
  if (number.empty() || *end != '\0' || !(value > 0.0) || !std::isfinite(value) ||
      (!seconds && value != std::floor(value)))
    throw std::invalid_argument("--checkpoint-every '" + text +
                                "': expected a whole number of steps (100) or of seconds with an s (60s)");
  if (seconds)
    run.checkpoint_every_seconds = value;
  else
    run.checkpoint_every_steps = static_cast<long>(value);
}

// Checks of the run command's own options (checkpoints): which go together.
void finish_run_command(const CLI::App* cmd, RunConfig& run, const std::string& every) {
  if (!every.empty()) {
    if (run.checkpoint_path.empty() && run.resume_path.empty())
      throw std::invalid_argument("--checkpoint-every needs --checkpoint FILE.h5 (or --resume FILE.h5)");
    set_checkpoint_every(run, every);
  }
  if (!run.checkpoint_path.empty() && !is_checkpoint_path(run.checkpoint_path))
    throw std::invalid_argument("--checkpoint " + run.checkpoint_path + ": a checkpoint is an HDF5 file: name it .h5");
  if (run.resume_path.empty()) return;
  // The run's options come from the checkpoint; only where to end and where to checkpoint may change.
  for (const CLI::Option* option : cmd->get_options()) {
    const std::string name = option->get_name();
    if (option->count() == 0 || name == "--resume" || name == "--t-end" || name == "--checkpoint" ||
        name == "--checkpoint-every" || name == "--help" || name == "--quiet" || name == "--verbose")
      continue;
    throw std::invalid_argument((name == "scene" ? std::string("a scene") : name) +
                                " with --resume: the run's options come from the checkpoint (only --t-end, "
                                "--checkpoint, --checkpoint-every, --quiet and --verbose may be given)");
  }
}

// The options of the run and batch commands, on their subcommands.
void add_run_command(CLI::App* cmd, RunOptions& run, std::string& checkpoint_every) {
  add_run_options(cmd, run);
  cmd->footer(kHelpFooter);
  cmd->add_option("--out", run.config.csv_path,
                  "write the trajectory to FILE.csv, or FILE.h5 / FILE.hdf5 (HDF5, with p, gap and the summary), or "
                  "- (CSV on standard output; the summary line then goes to standard error)");
  cmd->add_option("--every", run.config.every, "write every K-th step to the CSV (default 1)");
  cmd->add_option("--stop-when", run.config.stop_when,
                  "end the run (status=stopped, exit 0) where a condition first holds, checked after every step: "
                  "NAME>VALUE or NAME<VALUE for a coordinate (x0>10), hitch-angle>VALUE (radians, consecutive "
                  "planar bodies), gap>VALUE (holonomic constraints); repeatable")
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--threads", run.config.threads,
                  "threads for one step of the chain (--hitch oneform, a chain of knife edges and hitches): "
                  "default 0: a thread per 500 bodies, up to every core this process may use");
  cmd->add_option("--checkpoint", run.config.checkpoint_path,
                  "write the run's whole state to this HDF5 file at its end (also when it fails or is "
                  "interrupted), atomically; --resume continues it bit for bit");
  cmd->add_option("--checkpoint-every", checkpoint_every,
                  "also write the checkpoint every N steps, or every N seconds with Ns (60s)");
  cmd->add_option("--resume", run.config.resume_path,
                  "continue the run saved in this checkpoint (its options; --t-end may extend it); the output "
                  "file continues from where the checkpoint left it");
}

void add_batch_command(CLI::App* cmd, RunOptions& batch_run, BatchConfig& batch) {
  add_run_options(cmd, batch_run);
  cmd->footer(kHelpFooter);
  cmd->add_option("--count", batch.count, "number of trajectories")->required();
  cmd->add_option("--threads", batch.threads, "threads (default: all cores)");
  cmd->add_option("--vary", batch.vary, "draw a parameter per trajectory, NAME=LO:HI (repeatable)")
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--seed", batch.seed, "seed of the --vary draws (default 1)");
  cmd->add_option("--out", batch.out, "write one row per trajectory to this CSV file (or .h5: HDF5)");
  cmd->add_option("--states", batch.states,
                  "also write every trajectory's whole final state (q and p) to this HDF5 file: /q and /p, one "
                  "row per trajectory");
}

// The options as CLI11 writes them to a config file (`name=value` lines in declaration order,
// whatever their order and form on the command line), but --threads.
std::string canonical_options(const CLI::App* cmd) {
  std::istringstream lines(cmd->config_to_str(false, false));
  std::string kept;
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("threads=", 0) != 0) kept += line + "\n";
  return kept;
}

// A scene file's bytes, as one line of the command the ranks of `mpirun nonholo batch` agree on:
// two files of one name with other contents made one mixed table, the options being equal.
std::string scene_file_line(const std::string& scene) {
  if (!is_scene_file(scene)) return "";
  std::ifstream in(scene, std::ios::binary);
  if (!in) return "";  // the scene's reader says why
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::ostringstream os;
  os << "scene file " << scene << " of " << bytes.size() << " bytes, FNV-1a " << std::hex << fnv1a(bytes) << "\n";
  return os.str();
}

void finish_batch_command(const CLI::App* cmd, RunOptions& batch_run, BatchConfig& batch) {
  finish_run_options(cmd, batch_run);
  batch.command = canonical_options(cmd) + scene_file_line(batch_run.config.scene);
  if (cmd->count("--threads") && batch.threads < 1)
    throw std::invalid_argument("--threads " + std::to_string(batch.threads) + ": must be at least 1");
  check_batch_size(cmd, batch);
  batch.run = batch_run.config;
}

// Parses `nonholo <command> args...` with an app that has that command only (the library's and
// Python's way in); CLI11's own errors (an unknown option, a missing value) become
// std::invalid_argument with its message. An argument with a NUL byte would be cut there (argv
// holds C strings), and --help, -h or --version would end the parse with CLI11's internal text:
// both are refused naming the argument.
void parse_command(CLI::App& app, const std::string& command, const std::vector<std::string>& args) {
  std::vector<const char*> argv{"nonholo", command.c_str()};
  for (const auto& a : args) {
    if (a.find('\0') != std::string::npos)
      throw std::invalid_argument("argument " + std::to_string(argv.size() - 1) + " ('" +
                                  a.substr(0, a.find('\0')) + "\\0...') contains a NUL byte: arguments end at "
                                  "the first one, so the rest would be lost; remove it");
    argv.push_back(a.c_str());
  }
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::Success&) {  // --help, -h, --help-all, --version
    throw std::invalid_argument("the arguments ask for the command line's help, which this call does not print: "
                                "`nonholo " + command + " --help` prints it; in Python, help(nonholo." + command +
                                ") describes the keywords");
  } catch (const CLI::ParseError& e) {
    throw std::invalid_argument(e.what());
  }
}

void list_scenes(std::ostream& out) {
  for (const auto& info : scene_catalogue()) {
    out << info.name << ": " << info.description << " (dt " << info.default_dt << ", t_end "
        << info.default_t_end << ")\n";
    for (const auto& p : info.parameters) out << "  " << p.name << " = " << p.default_value << "  " << p.description << "\n";
  }
}

}  // namespace

namespace {

int dispatch(int argc, const char* const* argv, std::ostream& out, std::ostream& err, BatchProcesses* processes) {
  CLI::App app{"nonholo: momentum- and energy-preserving integration of nonholonomic systems"};
  app.set_version_flag("--version", std::string("nonholo ") + kVersion + " (git " + kGitRevision + ", " + kTargetArch + ")");
  app.require_subcommand(1);

  RunOptions run;
  std::string checkpoint_every;
  auto* run_cmd = app.add_subcommand("run", kRunHelp);
  add_run_command(run_cmd, run, checkpoint_every);

  RunOptions batch_run;
  BatchConfig batch;
  auto* batch_cmd = app.add_subcommand("batch", kBatchHelp);
  add_batch_command(batch_cmd, batch_run, batch);

  auto* list_cmd = app.add_subcommand("list", "the scenes with their parameters and defaults");

  WorkPrecisionConfig wp;
  auto* wp_cmd = app.add_subcommand("wp", "work-precision study of every method: CSV files for tools/work_precision.py");
  wp_cmd->add_option("--out", wp.directory, "directory for the CSV files (default wp)");
  wp_cmd->add_flag("--quick", wp.quick, "a few points only (seconds instead of minutes)");

  // Listed here for --help; the executable runs them in Python (scenarios/cli/python_commands.cpp).
  auto* animate_cmd = app.add_subcommand("animate", "a GIF or MP4 of a run's output file (nonholo animate --help)");
  auto* view_cmd = app.add_subcommand("view", "a self-contained HTML viewer of a run's output file (nonholo view --help)");
  for (CLI::App* python_cmd : {animate_cmd, view_cmd}) python_cmd->allow_extras()->set_help_flag();

  // CLI11 would only say that a subcommand is required; name the unknown word instead.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string word = argv[1];
    std::string commands;
    for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; }))
      commands += (commands.empty() ? "" : ", ") + command->get_name();
    if (app.get_subcommands([&](const CLI::App* command) { return command->get_name() == word; }).empty()) {
      say(err, "nonholo: unknown command '" + word + "' (commands: " + commands + ")");
      return 1;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e, out, err);
    return code == 0 ? 0 : 1;
  }

  const std::string name = app.get_subcommands().front()->get_name();
  try {
    if (list_cmd->parsed()) {
      list_scenes(out);
      return 0;
    }
    if (animate_cmd->parsed() || view_cmd->parsed())
      throw std::invalid_argument("`" + name + "` is run by the nonholo executable (Python: nonholo." + name + ")");
    if (processes && processes->size() > 1 && !batch_cmd->parsed())
      throw std::invalid_argument("only `batch` is spread over MPI ranks: start `" + name +
                                  "` without mpirun (or with -n 1)");
    if (wp_cmd->parsed()) {
      run_work_precision(wp, err);
      return 0;
    }
    if (batch_cmd->parsed()) {
      finish_batch_command(batch_cmd, batch_run, batch);
      batch.run.command_line = command_of("", std::vector<std::string>(argv + 1, argv + argc));
      batch.processes = processes;
      InterruptScope on_ctrl_c;  // Ctrl-C: finish the rows, print the summary, exit 130
      const BatchResult result = run_batch(batch);
      out << result.line() << std::endl;
      warn(err, "nonholo batch", result.aggregate, batch.run.verbosity);
      if (result.failed > 0) {
        say(err, "nonholo batch: " + std::to_string(result.failed) + " of " + std::to_string(result.trajectories) +
                     " trajectories failed; first: " + result.first_failure);
        if (interrupt_requested()) return kInterruptedExit;
        return result.failed == result.inaccurate ? kInaccurateExit : 2;
      }
      return 0;
    }
    finish_run_options(run_cmd, run);
    finish_run_command(run_cmd, run.config, checkpoint_every);
    run.config.command_line = command_of("", std::vector<std::string>(argv + 1, argv + argc));
    InterruptScope on_ctrl_c;
    const RunSummary summary = run_scene(run.config);
    (run.config.csv_path == "-" ? err : out) << summary.line() << std::endl;  // --out -: the CSV is stdout
    warn(err, "nonholo run", summary, run.config.verbosity);
    if (run.config.verbosity > 0 && !summary.threads_note.empty()) say(err, "nonholo run: note: " + summary.threads_note);
    if (run.config.verbosity > 0 && summary.status == Status::Stopped) say(err, "nonholo run: " + summary.message);
    if (summary.status != Status::Ok && summary.status != Status::Stopped) {
      say(err, "nonholo run: " + summary.message);
      if (summary.status == Status::Inaccurate) return kInaccurateExit;
      return summary.status == Status::Interrupted ? kInterruptedExit : 2;
    }
  } catch (const std::exception& e) {
    if (processes && batch_cmd->parsed()) processes->abandon();  // the other ranks may be waiting
    say(err, "nonholo " + name + ": " + e.what());
    return 1;
  }
  return 0;
}

}  // namespace

// What the command printed must reach its reader: standard output closed, full (/dev/full) or
// cut is an error with a message, not exit 0 with nothing said.
int run_command_line(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
                     BatchProcesses* processes) {
  const int code = dispatch(argc, argv, out, err, processes);
  out.flush();
  if (out) return code;
  err << "nonholo: could not write to standard output (closed, full or cut): what the command printed there "
         "(the summary, a table, a CSV sent to -) is lost; the output files are as written\n";
  return code == 0 ? 1 : code;
}

RunConfig parse_run_arguments(const std::vector<std::string>& args) {
  CLI::App app;
  RunOptions run;
  std::string checkpoint_every;
  auto* cmd = app.add_subcommand("run", kRunHelp);
  add_run_command(cmd, run, checkpoint_every);
  parse_command(app, "run", args);
  finish_run_options(cmd, run);
  finish_run_command(cmd, run.config, checkpoint_every);
  run.config.command_line = command_of("run", args) + " (from Python)";
  return run.config;
}

BatchConfig parse_batch_arguments(const std::vector<std::string>& args) {
  CLI::App app;
  RunOptions batch_run;
  BatchConfig batch;
  auto* cmd = app.add_subcommand("batch", kBatchHelp);
  add_batch_command(cmd, batch_run, batch);
  parse_command(app, "batch", args);
  finish_batch_command(cmd, batch_run, batch);
  batch.run.command_line = command_of("batch", args) + " (from Python)";
  return batch;
}

}  // namespace nonholo::scenarios
