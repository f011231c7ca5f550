#include <nonholo/scenarios/command_line.hpp>

#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/work_precision.hpp>

#include <CLI/CLI.hpp>

#include <ostream>
#include <string>
#include <stdexcept>

namespace nonholo::scenarios {

int run_command_line(int argc, const char* const* argv, std::ostream& out, std::ostream& err) {
  CLI::App app{"nonholo: momentum- and energy-preserving integration of nonholonomic systems"};
  app.require_subcommand(1);

  RunConfig run;
  std::string backend = "auto", hitch = "holonomic";
  auto* cmd = app.add_subcommand("run", "integrate one scene and print a summary line");
  cmd->add_option("scene", run.scene, "scene name (particle, sleigh, sleigh_contact, snakeboard, sleigh_chain, wheeled_train)")->required();
  cmd->add_option("--dt", run.dt, "time step (default: the scene's)");
  cmd->add_option("--t-end", run.t_end, "final time (default: the scene's)");
  cmd->add_option("--set", run.assignments, "set a scene parameter, NAME=VALUE (repeatable)")
      ->take_all()
      ->allow_extra_args(false);
  cmd->add_option("--out", run.csv_path, "write the trajectory to this CSV file");
  cmd->add_option("--every", run.every, "write every K-th step to the CSV (default 1)");
  cmd->add_option("--backend", backend,
                  "factorisation of C: auto, block-diagonal, dense, cholmod-natural, cholmod-amd");
  cmd->add_option("--hitch", hitch, "hitches: holonomic (position level, default) or oneform");
  cmd->add_option("--method", run.method,
                  "reflection (default), dla-midpoint, dla-left, rk4, arkode-dp5, arkode-verner (the "
                  "last three integrate the index-reduced equations; --dt is then RK4's step or "
                  "ARKODE's output interval)");
  cmd->add_flag("--project", run.project,
                "rk4 and arkode-*: project onto the constraints (and hitches) after every step");
  cmd->add_option("--tol", run.tol, "arkode-*: relative and absolute tolerance (default 1e-8)");
  cmd->add_option("--restart", run.restart,
                  "reset the multipliers to the continuous ones every K steps (0: never; "
                  "default: the scene's)");

  WorkPrecisionConfig wp;
  auto* wp_cmd = app.add_subcommand("wp", "work-precision study of every method: CSV files for tools/work_precision.py");
  wp_cmd->add_option("--out", wp.directory, "directory for the CSV files (default wp)");
  wp_cmd->add_flag("--quick", wp.quick, "a few points only (seconds instead of minutes)");

  // CLI11 would only say that a subcommand is required; name the unknown word instead.
  if (argc > 1 && argv[1][0] != '-' && std::string(argv[1]) != "run" && std::string(argv[1]) != "wp") {
    err << "nonholo: unknown command '" << argv[1] << "' (commands: run, wp)" << std::endl;
    return 1;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e, out, err);
    return code == 0 ? 0 : 1;
  }

  if (wp_cmd->parsed()) {
    try {
      run_work_precision(wp, err);
    } catch (const std::exception& e) {
      err << "nonholo wp: " << e.what() << std::endl;
      return 1;
    }
    return 0;
  }
  try {
    if (cmd->count("--dt") && !(run.dt > 0.0))
      throw std::invalid_argument("--dt " + std::to_string(run.dt) + ": the step must be positive");
    if (run.method != "reflection") {
      for (const char* option : {"--hitch", "--restart"})
        if (cmd->count(option))
          throw std::invalid_argument(std::string(option) + " applies to the reflection method only");
    } else if (cmd->count("--tol")) {
      throw std::invalid_argument("--tol applies to the methods arkode-dp5 and arkode-verner");
    }
    if (cmd->count("--restart") && run.restart < 0)
      throw std::invalid_argument("--restart " + std::to_string(run.restart) + ": must be 0 (never) or positive");
    if (cmd->count("--t-end") && !(run.t_end >= 0.0))
      throw std::invalid_argument("--t-end " + std::to_string(run.t_end) + ": must be non-negative");
    run.backend = sparse::backend_from_string(backend);
    run.hitch = hitch_mode_from_string(hitch);
    const RunSummary summary = run_scene(run);
    out << summary.line() << std::endl;
    if (summary.status != Status::Ok) {
      err << "nonholo run: " << summary.message << std::endl;
      return 2;
    }
  } catch (const std::exception& e) {
    err << "nonholo run: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}

}  // namespace nonholo::scenarios
