// `nonholo wp` (work_precision.hpp): the work-precision table against an oracle, long-time and equal-cost
// runs, the error estimates against the truth and the paper's experiments, each as CSV.
#include <nonholo/scenarios/work_precision.hpp>

#include <nonholo/scenarios/exact_solutions.hpp>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "run/runners.hpp"

namespace nonholo::scenarios {
namespace {

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Sample {
  double t;
  Vector q;
  Diagnostics d;
};

struct Trajectory {
  std::vector<Sample> samples;  // at t0 and every sample_dt
  double cpu_s = 0.0;
  long rhs = -1;
  long factorizations = -1;
  long steps = 0;
  long restarts = -1;  // reflection: multiplier restarts
  Status status = Status::Ok;
  std::string message;
};

// Integrates with steps of `choice`'s h (ARKODE and adaptive steps: to each sample time),
// sampling every sample_dt.
Trajectory integrate(const SceneSetup& setup, const MethodChoice& choice, double t_end, double sample_dt) {
  Trajectory out;
  auto runner = make_runner(setup.model, RunStart{setup.t0, setup.q0, setup.v0, {}}, choice);
  const bool own_steps = choice.method.rfind("arkode", 0) == 0 || choice.adaptive_on();
  const double dt = own_steps ? sample_dt : choice.rattle.h;
  const long steps = std::lround(t_end / dt), every = std::max(1L, std::lround(sample_dt / dt));
  if (std::abs(static_cast<double>(every) * dt - sample_dt) > 1e-9 * sample_dt)
    throw std::logic_error("work-precision: the step " + std::to_string(dt) + " does not divide the sample interval");
  const double t0 = runner->t();
  out.samples.push_back({runner->t(), runner->q(), runner->diagnostics()});
  double sampling = 0.0;
  const double start = cpu_seconds();
  for (long k = 1; k <= steps; ++k) {
    out.status = runner->advance(t0 + static_cast<double>(k) * dt);
    if (out.status != Status::Ok) {
      out.message = runner->message();
      break;
    }
    out.steps = k;
    if (k % every == 0) {
      const double s0 = cpu_seconds();
      out.samples.push_back({runner->t(), runner->q(), runner->diagnostics()});
      sampling += cpu_seconds() - s0;
    }
  }
  out.cpu_s = cpu_seconds() - start - sampling;
  out.rhs = runner->rhs_evaluations();
  out.factorizations = runner->factorizations();
  out.restarts = runner->restarts();
  if (choice.adaptive_on()) out.steps = runner->internal_steps();  // accepted, not output intervals
  return out;
}

double relative(double value, double reference) {
  return reference != 0.0 ? std::abs(value - reference) / std::abs(reference) : std::abs(value - reference);
}

SceneSetup build(const std::string& scene, const std::vector<std::string>& sets) {
  const SceneInfo& info = find_scene(scene);
  Parameters p = info.defaults();
  for (const auto& s : sets) p.assign(s);
  return info.build(p);
}

struct Case {
  std::string scene;
  std::vector<std::string> sets;
  std::string label;
  HitchMode hitch = HitchMode::Holonomic;  // the reflection method's
};

// The oracle's configuration at the sample times: the exact solution where docs/design.md
// section 6 gives one, otherwise ARKODE Fehlberg 8(7) at tolerance `tol` (at 1e-14 it meets
// order 8 at H = 0.05 to 5e-12 on a 100-body chain at t = 100, bench_time_to_error; Verner
// 6(5), the oracle before, was 1e-9 off there).
std::vector<Vector> oracle(const Case& c, const SceneSetup& setup, double t_end, double sample_dt,
                           double tol = 1e-14) {
  std::vector<Vector> out;
  const long n = std::lround(t_end / sample_dt);
  if (c.scene == "sleigh" && c.sets.empty()) {
    const SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
    std::vector<double> times;
    for (long k = 0; k <= n; ++k) times.push_back(static_cast<double>(k) * sample_dt);
    const auto centre = exact.positions(times);  // one quadrature pass for all times
    for (long k = 0; k <= n; ++k)
      out.push_back(Eigen::Vector3d(centre[k][0], centre[k][1], exact.heading(times[k])));
    return out;
  }
  if (c.scene == "particle" && c.sets.empty()) {
    const ParticleExact exact(0.0, 0.0, 0.0, 1.0, 1.0);
    for (long k = 0; k <= n; ++k) out.push_back(exact.configuration(static_cast<double>(k) * sample_dt));
    return out;
  }
  MethodChoice reference;
  reference.method = "arkode-fehlberg8";
  reference.reference.tol = tol;
  const Trajectory t = integrate(setup, reference, t_end, sample_dt);
  if (t.status != Status::Ok) throw std::runtime_error("oracle failed for " + c.label + ": " + t.message);
  for (const auto& s : t.samples) out.push_back(s.q);
  return out;
}

std::ofstream open(const std::filesystem::path& path) {
  std::ofstream f(path);
  if (!f) throw std::invalid_argument("cannot open '" + path.string() + "' for writing: " + std::strerror(errno));
  f.precision(10);
  return f;
}

struct MethodPoint {
  std::string method;
  bool project;
  double h, tol;
  int order = 2;  // reflection: 4, 6 and 8 compose plain steps (h is the composed step)
  double horizon = 0.0;  // reflection: adaptive steps at `tol` over this run length (0: fixed)
};

// The method's name in the CSV files: reflection-o4 ... -o8 for the composed orders,
// reflection-a2 ... -a8 for adaptive steps.
std::string label_of(const std::string& method, int order, bool adaptive = false) {
  return adaptive ? method + "-a" + std::to_string(order) : order > 2 ? method + "-o" + std::to_string(order) : method;
}
std::string label_of(const MethodPoint& pt) { return label_of(pt.method, pt.order, pt.horizon > 0.0); }

MethodChoice choice_of(const MethodPoint& pt) {
  MethodChoice choice;
  if (pt.horizon > 0.0) {
    choice.adaptive.tol = pt.tol;
    choice.adaptive.horizon = pt.horizon;
  }
  choice.method = pt.method;
  choice.rattle.h = pt.h > 0.0 ? pt.h : 0.01;
  choice.rattle.order = pt.order;
  choice.reference.h = choice.rattle.h;
  choice.reference.tol = pt.tol > 0.0 ? pt.tol : 1e-8;
  choice.reference.project = pt.project;
  return choice;
}

// max_k |q_k - truth_k| over the samples both have.
double max_error(const Trajectory& tr, const std::vector<Vector>& truth) {
  double error = 0.0;
  for (std::size_t k = 0; k < tr.samples.size() && k < truth.size(); ++k)
    error = std::max(error, (tr.samples[k].q - truth[k]).lpNorm<Eigen::Infinity>());
  return tr.status == Status::Ok ? error : std::numeric_limits<double>::quiet_NaN();
}

void work_precision_table(const WorkPrecisionConfig& config, std::ostream& log) {
  const double t_end = 10.0, sample_dt = 0.5;
  std::vector<Case> cases{{"particle", {}, "particle"},
                          {"sleigh", {}, "sleigh"},
                          {"snakeboard", {}, "snakeboard"},
                          {"sleigh_chain", {"bodies=100"}, "sleigh_chain_100"},
                          {"sleigh_chain", {"bodies=10"}, "sleigh_chain_10_oneform", HitchMode::OneForm},
                          {"sleigh_chain", {"bodies=100"}, "sleigh_chain_100_oneform", HitchMode::OneForm},
                          {"wheeled_train", {"bodies=20"}, "wheeled_train_20"}};
  std::vector<double> steps{0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
  std::vector<double> composed_steps{0.5, 0.25, 0.1, 0.05, 0.025, 0.01};
  std::vector<double> tols{1e-4, 1e-6, 1e-8, 1e-10, 1e-12};
  if (config.quick) {
    steps = {0.05, 0.02};
    composed_steps = {0.25, 0.1};
    tols = {1e-6};
    cases.resize(2);
  }
  std::vector<MethodPoint> points;
  for (const char* m : {"reflection", "dla-midpoint", "dla-left", "rk4"})
    for (double h : steps) points.push_back({m, false, h, 0.0});
  for (double h : steps) points.push_back({"rk4", true, h, 0.0});
  for (int order : {4, 6, 8})
    for (double h : composed_steps) points.push_back({"reflection", false, h, 0.0, order});
  // Adaptive steps; orders 2 and 4 not at tolerances that would take 10^5 steps or more.
  for (int order : {2, 4, 6, 8})
    for (double tol : tols)
      if (tol >= (order == 2 ? 1e-6 : order == 4 ? 1e-10 : 0.0)) points.push_back({"reflection", false, 0.0, tol, order, t_end});
  for (const char* m : {"arkode-dp5", "arkode-verner", "arkode-fehlberg8"})
    for (double tol : tols) points.push_back({m, false, 0.0, tol});
  for (double tol : tols) points.push_back({"arkode-dp5", true, 0.0, tol});

  auto csv = open(std::filesystem::path(config.directory) / "work_precision.csv");
  csv << "scene,method,project,h,tol,cpu_s,rhs_evals,factorizations,steps,error,energy_err,energy_post_err,residual,"
         "status\n";
  for (const Case& c : cases) {
    const SceneSetup setup = build(c.scene, c.sets);
    const auto truth = oracle(c, setup, t_end, sample_dt);
    for (const MethodPoint& pt : points) {
      MethodChoice choice = choice_of(pt);
      choice.rattle.hitch = c.hitch;
      const Trajectory tr = integrate(setup, choice, t_end, sample_dt);
      const double error = max_error(tr, truth);
      double energy = 0.0, energy_post = 0.0, residual = 0.0;
      const Diagnostics& d0 = tr.samples.front().d;
      for (const Sample& s : tr.samples) {
        energy = std::max(energy, relative(s.d.energy, d0.energy));
        energy_post = std::isnan(d0.energy_post) ? d0.energy_post
                                                 : std::max(energy_post, relative(s.d.energy_post, d0.energy_post));
        residual = std::max(residual, s.d.residual);
      }
      csv << c.label << "," << label_of(pt) << "," << (pt.project ? 1 : 0) << "," << pt.h << ","
          << pt.tol << "," << tr.cpu_s << "," << tr.rhs << "," << tr.factorizations << "," << tr.steps << "," << error << "," << energy << "," << energy_post
          << "," << residual << "," << to_string(tr.status) << "\n";
      log << "wp " << c.label << " " << label_of(pt) << (pt.project ? "+project" : "") << " h=" << pt.h
          << " tol=" << pt.tol << ": error " << error << ", cpu " << tr.cpu_s << " s\n";
    }
  }
}

// Long runs with every method, the reflection method both with its default automatic restarts
// and as the paper's plain method: energy errors, residual and, where an oracle is cheap
// enough (the sleigh's exact solution; ARKODE at 1e-12 for the 10-body chain), the error.
void long_time(const WorkPrecisionConfig& config, std::ostream& log) {
  auto csv = open(std::filesystem::path(config.directory) / "long_time.csv");
  csv << "scene,method,t,energy_err,energy_post_err,residual,error,restarts\n";
  struct Run {
    Case c;
    double t_end, sample;
    HitchMode hitch;
    bool with_oracle;
  };
  auto method = [](const char* name, HitchMode hitch, const char* restart = "auto") {
    MethodChoice m;
    m.method = name;
    m.rattle.hitch = hitch;
    set_restart(m.rattle.restart, restart);
    m.reference.tol = 1e-8;
    return m;
  };
  const bool quick = config.quick;
  const std::vector<Run> runs{
      {{"sleigh", {}, "sleigh"}, quick ? 50.0 : 1e4, quick ? 1.0 : 10.0, HitchMode::Holonomic, true},
      {{"sleigh_chain", {"bodies=10"}, "sleigh_chain_10_oneform"}, quick ? 5.0 : 100.0, 1.0, HitchMode::OneForm, true},
      {{"sleigh_chain", {"bodies=100"}, "sleigh_chain_100"}, quick ? 5.0 : 1e3, 1.0, HitchMode::Holonomic, false}};
  for (const Run& r : runs) {
    const SceneSetup setup = build(r.c.scene, r.c.sets);
    const std::vector<Vector> truth = r.with_oracle ? oracle(r.c, setup, r.t_end, r.sample) : std::vector<Vector>{};
    for (const MethodChoice& m : {method("reflection", r.hitch), method("reflection", r.hitch, "0"),
                                  method("dla-midpoint", r.hitch), method("rk4", r.hitch), method("arkode-dp5", r.hitch)}) {
      const Trajectory tr = integrate(setup, m, r.t_end, r.sample);
      const bool plain = m.method == "reflection" && m.rattle.restart.mode == RestartMode::Never;
      const std::string label = m.method + (plain ? "+plain" : "");
      const Diagnostics& d0 = tr.samples.front().d;
      for (std::size_t k = 0; k < tr.samples.size(); ++k) {
        const Sample& s = tr.samples[k];
        const double error = k < truth.size() ? (s.q - truth[k]).lpNorm<Eigen::Infinity>()
                                              : std::numeric_limits<double>::quiet_NaN();
        csv << r.c.label << "," << label << "," << s.t << "," << relative(s.d.energy, d0.energy) << ","
            << relative(s.d.energy_post, d0.energy_post) << "," << s.d.residual << "," << error << "," << tr.restarts
            << "\n";
      }
      log << "long " << r.c.label << " " << label << " to t = " << tr.samples.back().t << ": "
          << to_string(tr.status) << ", cpu " << tr.cpu_s << " s";
      if (tr.restarts >= 0) log << ", " << tr.restarts << " restarts";
      log << "\n";
    }
  }
}

// Long runs at equal cost (t = 1000): the sixth-order composition against RK4 at the same
// number of factorisations per unit time and ARKODE Verner over a range of tolerances, on the
// sleigh (exact solution) and a 10-body chain (ARKODE at 1e-13 as the oracle).
void equal_cost(const WorkPrecisionConfig& config, std::ostream& log) {
  auto csv = open(std::filesystem::path(config.directory) / "equal_cost.csv");
  csv << "scene,method,h,tol,cpu_s,factorizations,error_final,error_max,energy_err_max,residual_max,status\n";
  const double t_end = config.quick ? 20.0 : 1000.0, sample = config.quick ? 1.0 : 10.0;
  // Per unit time: order 6 at H = 0.2 and order 4 at H = 0.1 take 90 and 100 factorisations,
  // RK4 at h = 0.04 100, order 2 at h = 0.02 50.
  const std::vector<MethodPoint> points{{"reflection", false, 0.2, 0.0, 6}, {"reflection", false, 0.1, 0.0, 4},
                                        {"reflection", false, 0.02, 0.0, 2}, {"rk4", false, 0.04, 0.0},
                                        {"arkode-verner", false, 0.0, 1e-9},   {"arkode-verner", false, 0.0, 1e-10},
                                        {"arkode-verner", false, 0.0, 1e-11},  {"arkode-verner", false, 0.0, 1e-12}};
  for (const Case& c : {Case{"sleigh", {}, "sleigh"}, Case{"sleigh_chain", {"bodies=10"}, "sleigh_chain_10"}}) {
    const SceneSetup setup = build(c.scene, c.sets);
    const std::vector<Vector> truth = oracle(c, setup, t_end, sample, 1e-13);
    for (const MethodPoint& pt : points) {
      const Trajectory tr = integrate(setup, choice_of(pt), t_end, sample);
      const Diagnostics& d0 = tr.samples.front().d;
      double energy = 0.0, residual = 0.0;
      for (const Sample& smp : tr.samples) {
        energy = std::max(energy, relative(smp.d.energy, d0.energy));
        residual = std::max(residual, smp.d.residual);
      }
      const bool complete = tr.status == Status::Ok && tr.samples.size() == truth.size();
      const double final_error = complete ? (tr.samples.back().q - truth.back()).lpNorm<Eigen::Infinity>()
                                          : std::numeric_limits<double>::quiet_NaN();
      const double error = max_error(tr, truth);
      csv << c.label << "," << label_of(pt.method, pt.order) << "," << pt.h << "," << pt.tol << "," << tr.cpu_s << ","
          << tr.factorizations << "," << final_error << "," << error << "," << energy << "," << residual << ","
          << to_string(tr.status) << "\n";
      log << "equal cost " << c.label << " " << label_of(pt.method, pt.order) << " h=" << pt.h << " tol=" << pt.tol
          << ": error at t = " << t_end << " " << final_error << ", " << tr.factorizations << " factorisations, cpu "
          << tr.cpu_s << " s\n";
    }
  }
}

// How close --error-estimate comes to the true error: the estimate (the companion at h/2,
// Richardson-scaled, or ARKODE at tol/100) against the oracle, max over the samples.
void error_estimates(const WorkPrecisionConfig& config, std::ostream& log) {
  auto csv = open(std::filesystem::path(config.directory) / "error_estimate.csv");
  csv << "scene,method,h,tol,error,estimate,ratio\n";
  const double t_end = 10.0, sample_dt = 0.5;
  std::vector<MethodPoint> points{{"reflection", false, 0.05, 0.0, 2}, {"reflection", false, 0.01, 0.0, 2},
                                  {"reflection", false, 0.25, 0.0, 4}, {"reflection", false, 0.125, 0.0, 4},
                                  {"reflection", false, 0.5, 0.0, 6},  {"reflection", false, 0.25, 0.0, 6},
                                  {"dla-midpoint", false, 0.05, 0.0},  {"rk4", false, 0.05, 0.0},
                                  {"rk4", false, 0.02, 0.0},           {"arkode-verner", false, 0.0, 1e-6},
                                  {"arkode-verner", false, 0.0, 1e-8}, {"arkode-verner", false, 0.0, 1e-10}};
  std::vector<Case> cases{{"sleigh", {}, "sleigh"}, {"particle", {}, "particle"},
                          {"sleigh_chain", {"bodies=10"}, "sleigh_chain_10"}};
  if (config.quick) {
    points.resize(3);
    cases.resize(1);
  }
  for (const Case& c : cases) {
    const SceneSetup setup = build(c.scene, c.sets);
    const auto truth = oracle(c, setup, t_end, sample_dt);
    for (const MethodPoint& pt : points) {
      const MethodChoice choice = choice_of(pt);
      const Companion companion = companion_of(choice);
      const Trajectory tr = integrate(setup, choice, t_end, sample_dt);
      const Trajectory fine = integrate(setup, companion.choice, t_end, sample_dt);
      std::vector<Vector> fine_q;
      for (const Sample& smp : fine.samples) fine_q.push_back(smp.q);
      const double error = max_error(tr, truth);
      const double estimate = fine.status == Status::Ok ? companion.scale * max_error(tr, fine_q)
                                                        : std::numeric_limits<double>::quiet_NaN();
      csv << c.label << "," << label_of(pt.method, pt.order) << "," << pt.h << "," << pt.tol << "," << error << ","
          << estimate << "," << estimate / error << "\n";
      log << "estimate " << c.label << " " << label_of(pt.method, pt.order) << " h=" << pt.h << " tol=" << pt.tol
          << ": error " << error << ", estimate " << estimate << "\n";
    }
  }
}

// The paper's section 6: the particle's energy (ours and DLA), the sleigh's error against the
// continuous trajectory (ours, DLA midpoint and left point), the controlled snakeboard's path.
void paper(const WorkPrecisionConfig& config, std::ostream& log) {
  const std::filesystem::path dir(config.directory);
  {
    auto csv = open(dir / "paper_particle_energy.csv");
    csv << "method,t,energy\n";
    const SceneSetup setup = build("particle", {});
    for (const char* name : {"reflection", "dla-midpoint"}) {
      MethodChoice m;
      m.method = name;
      m.rattle.h = 0.1;
      const Trajectory tr = integrate(setup, m, config.quick ? 10.0 : 100.0, 0.1);
      for (const Sample& s : tr.samples) csv << name << "," << s.t << "," << s.d.energy_post << "\n";
    }
  }
  {
    auto csv = open(dir / "paper_sleigh_error.csv");
    csv << "method,t,error\n";
    const SceneSetup setup = build("sleigh", {});
    const SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
    for (const char* name : {"reflection", "dla-midpoint", "dla-left"}) {
      MethodChoice m;
      m.method = name;
      m.rattle.h = 0.05;
      const Trajectory tr = integrate(setup, m, 10.0, 0.05);
      for (const Sample& s : tr.samples)
        csv << name << "," << s.t << "," << (s.q - exact.configuration(s.t)).norm() << "\n";
    }
  }
  {
    // From rest, rider and axle torques sinusoidal with the same frequency and phase. A
    // torque U sin(w t) from rest gives the free axle angle a mean rate U / (2 J1 w) (it drifts
    // round), so the torques are cosines (phase pi/2) and the axles start at the turning point
    // of their oscillation, phi0 = -U / (2 J1 w^2) = -0.5 (the board itself is at rest).
    auto csv = open(dir / "paper_snakeboard_path.csv");
    csv << "t,x,y,theta,psi,phi\n";
    const SceneSetup setup = build("snakeboard", {"v0=0", "psi_dot0=0", "phi_dot0=0", "phi0=-0.5",
                                                  "u_psi_amp=-0.2", "u_phi_amp=0.04", "u_psi_omega=2",
                                                  "u_phi_omega=2", "u_psi_phase=1.5707963267948966",
                                                  "u_phi_phase=1.5707963267948966"});
    MethodChoice m;
    m.rattle.h = 0.01;
    const Trajectory tr = integrate(setup, m, config.quick ? 5.0 : 20.0, 0.05);
    for (const Sample& s : tr.samples) {
      csv << s.t;
      for (Eigen::Index i = 0; i < s.q.size(); ++i) csv << "," << s.q[i];
      csv << "\n";
    }
    log << "paper snakeboard: " << to_string(tr.status) << " to t = " << tr.samples.back().t << ", x = "
        << tr.samples.back().q[0] << "\n";
  }
}

}  // namespace

void run_work_precision(const WorkPrecisionConfig& config, std::ostream& log) {
  std::error_code ec;
  std::filesystem::create_directories(config.directory, ec);
  if (ec) throw std::invalid_argument("cannot create '" + config.directory + "': " + ec.message());
  work_precision_table(config, log);
  long_time(config, log);
  equal_cost(config, log);
  error_estimates(config, log);
  paper(config, log);
}

}  // namespace nonholo::scenarios
