// Time to reach a given accuracy: on a free hitched chain of 10 and of 100 bodies to t = 100,
// the error in q at t = 100, for the reflection method of orders 4, 6 and 8 (default
// compositions, one-form and holonomic hitches), adaptive composed steps of orders 6 and 8
// (setting = tol), RK4, and ARKODE's Verner 6(5) and Fehlberg 8(7) pairs. The oracle is
// ARKODE Fehlberg 8(7) at tolerance 1e-15, checked against order 8
// with one-form hitches at H = 0.05 (they agree to 4e-13 with 10 bodies and 5e-12 with 100;
// ARKODE Verner at 1e-13, the oracle before, was 1.2e-10 and 1.2e-9 off). Before timing, each
// method's step (or tolerance) is searched for the largest one (loosest one) whose error is at
// most 1e-8 or 1e-10; the benchmark then times one whole run at that setting. Counters: the
// setting, the error reached and the factorisations of C (evaluations for RK4 and ARKODE).
#include <nonholo/adaptive.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace nonholo;

constexpr double kT = 100.0;

scenarios::SceneSetup build(int bodies) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto p = info.defaults();
  p.set("bodies", bodies);
  return info.build(p);
}

struct Chain {
  scenarios::SceneSetup setup;
  Vector v0;      // the consistent start velocity M^-1 p~_0
  Vector truth;   // q(T) from ARKODE Fehlberg 8(7) at 1e-15
  explicit Chain(int bodies) : setup(build(bodies)) {
    Workspace ws(setup.model);
    State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
    v0.resize(s.p.size());
    setup.model.inverse_mass().multiply(s.p.data(), v0.data());
    reference::Options o;
    o.tol = 1e-15;
    reference::Integrator ref(setup.model, reference::Method::ArkodeFehlberg8, o, 0.0, setup.q0, v0);
    if (ref.advance_to(kT) != Status::Ok) throw std::runtime_error("oracle: " + ref.message());
    truth = ref.q();
    RattleOptions fine;  // the independent check: order 8 at H = 0.05
    fine.h = 0.05;
    fine.order = 8;
    fine.hitch = HitchMode::OneForm;
    for (long k = 0; k < std::lround(kT / fine.h); ++k)
      if (step(setup.model, ws, s, fine) != Status::Ok) throw std::runtime_error(std::string("order-8 check: ") + ws.message());
    std::cerr << "oracle, " << bodies << " bodies: Fehlberg 8(7) at 1e-15 and order 8 at H = 0.05 differ by "
              << (s.q - truth).lpNorm<Eigen::Infinity>() << "\n";
  }
};

Chain& chain(int bodies) {
  static std::map<int, std::unique_ptr<Chain>> cache;
  auto& c = cache[bodies];
  if (!c) c = std::make_unique<Chain>(bodies);
  return *c;
}

struct Outcome {
  double error = NAN;
  long factorizations = 0;
};

// One run to T. method: "o2", "o4", "o6", "o8" with "-oneform" or "-holonomic", "rk4"
// (setting = the step), "verner" or "fehlberg8" (= tol), "a6", "a8" with a hitch (adaptive, = tol).
Outcome run(const Chain& c, const std::string& method, double setting) {
  const Model& model = c.setup.model;
  Outcome out;
  if (method == "rk4" || method == "verner" || method == "fehlberg8") {
    reference::Options o;
    (method == "rk4" ? o.h : o.tol) = setting;
    const reference::Method m = method == "rk4"      ? reference::Method::Rk4
                                : method == "verner" ? reference::Method::ArkodeVerner
                                                     : reference::Method::ArkodeFehlberg8;
    reference::Integrator integ(model, m, o, 0.0, c.setup.q0, c.v0);
    if (integ.advance_to(kT) != Status::Ok) return out;
    out.error = (integ.q() - c.truth).lpNorm<Eigen::Infinity>();
    out.factorizations = integ.ode().workspace().factorizations;
    return out;
  }
  RattleOptions o;
  o.order = method[1] - '0';
  o.hitch = method.find("oneform") != std::string::npos ? HitchMode::OneForm : HitchMode::Holonomic;
  if (method[0] == 'a') {  // adaptive composed steps at tolerance `setting`
    Workspace ws(model, {sparse::Backend::Auto, true});
    State s = start_from_velocity(model, ws, 0.0, c.setup.q0, c.setup.v0);
    AdaptiveOptions a;
    a.tol = setting;
    a.horizon = kT;
    AdaptiveStepper stepper(model, o, a);
    while (s.t < kT)
      if (stepper.step(model, ws, s, kT) != Status::Ok) {
        std::cerr << method << " tol " << setting << ": " << ws.message() << "\n";
        return out;
      }
    out.error = (s.q - c.truth).lpNorm<Eigen::Infinity>();
    out.factorizations = ws.factorizations;
    return out;
  }
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, c.setup.q0, c.setup.v0);
  o.h = setting;
  const long steps = std::lround(kT / setting);
  for (long k = 0; k < steps; ++k)
    if (step(model, ws, s, o) != Status::Ok) return out;
  out.error = (s.q - c.truth).lpNorm<Eigen::Infinity>();
  out.factorizations = ws.factorizations;
  return out;
}

// The cheapest setting that reaches `target`: fixed steps T/K with K chosen from the error's
// power law and raised until the target holds; tolerances by factors of 10^(1/4).
double setting_for(const Chain& c, const std::string& method, double target) {
  if (method == "verner" || method == "fehlberg8" || method[0] == 'a') {
    for (double tol = 10.0 * target; tol >= 1e-15; tol /= std::pow(10.0, 0.25))
      if (run(c, method, tol).error <= target) return tol;
    return NAN;
  }
  const double order = method == "rk4" ? 4.0 : method[1] - '0';
  long steps = method[1] == '2' ? 2000 : method == "rk4" ? 1000 : 100;
  for (int trial = 0; trial < 40; ++trial) {
    const double e = run(c, method, kT / static_cast<double>(steps)).error;
    if (e <= target) {  // walk back while the target still holds (at most a few per cent)
      while (steps > 1 && run(c, method, kT / static_cast<double>(steps - steps / 50 - 1)).error <= target)
        steps -= steps / 50 + 1;
      return kT / static_cast<double>(steps);
    }
    // (A blown-up run, error huge or NaN, only doubles the steps.)
    const double factor = std::isfinite(e) ? std::pow(e / target, 1.0 / order) * 1.02 : 2.0;
    steps = static_cast<long>(std::ceil(static_cast<double>(steps) * std::clamp(factor, 1.02, 4.0)));
  }
  return NAN;
}

void time_to_error(benchmark::State& bench, int bodies, std::string method, double target) {
  const Chain& c = chain(bodies);
  const double setting = setting_for(c, method, target);
  if (!std::isfinite(setting)) {
    bench.SkipWithError("no setting reaches the target");
    return;
  }
  Outcome out;
  for (auto _ : bench) {
    out = run(c, method, setting);
    benchmark::DoNotOptimize(out.error);
  }
  bench.counters["setting"] = setting;  // the step, or ARKODE's tolerance
  bench.counters["error"] = out.error;
  bench.counters["factorizations"] = static_cast<double>(out.factorizations);
}

void register_all() {
  for (int bodies : {10, 100})
    for (double target : {1e-8, 1e-10})
      for (const char* method : {"a6-oneform", "a8-oneform", "o8-oneform", "o8-holonomic", "o6-oneform",
                                 "o6-holonomic", "o4-oneform", "rk4", "verner", "fehlberg8"}) {
        const std::string name = "TimeToError/chain" + std::to_string(bodies) + "/" + (target == 1e-8 ? "1e-8" : "1e-10") +
                                 "/" + method;
        benchmark::RegisterBenchmark(name.c_str(), time_to_error, bodies, std::string(method), target)
            ->Unit(benchmark::kMillisecond)
            ->Iterations(bodies == 10 ? 5 : 1);
      }
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
