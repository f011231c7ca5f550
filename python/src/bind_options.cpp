// The options and statuses in Python: Status, RattleOptions (with RestartOptions and the
// hitch modes, compositions and rotation Lagrangians), WorkspaceOptions and the backends.
#include "bind_common.hpp"

namespace nonholo::python {

void bind_status(py::module_& m) {
  py::enum_<Status> e(m, "Status", "What a step reports (core/include/nonholo/status.hpp); Status.Ok on success.");
  // Named as in C++, from the library's names ("callback-failed" -> CallbackFailed), up to the
  // last enumerator (kLastStatus).
  for (int i = 0; i <= static_cast<int>(kLastStatus); ++i) {
    const auto s = static_cast<Status>(i);
    std::string name;
    bool upper = true;
    for (const char* c = to_string(s); *c; ++c) {
      if (*c == '-') {
        upper = true;
        continue;
      }
      name += upper ? static_cast<char>(std::toupper(static_cast<unsigned char>(*c))) : *c;
      upper = false;
    }
    e.value(name.c_str(), s);
  }
  // pybind11's own `value` has no docstring: the same property again, documented.
  e.def_property_readonly("value", [](Status s) { return static_cast<int>(s); },
                          "The enumerator's integer value, as in C++ (Status.Ok is 0).");
  e.def_property_readonly("text", [](Status s) { return to_string(s); },
                          "The library's name for it, as the command line prints it: 'ok', 'callback-failed', ...");
}

namespace {

// The constructor, every field a keyword argument with the library's default.
void rattle_constructor(py::class_<RattleOptions>& c) {
  const RattleOptions d;
  c.def(py::init([](double h, double min_pivot_ratio, const std::string& hitch, double gap_tolerance,
                    double gap_tolerance_limit, int max_gap_iterations, const std::string& restart,
                    double restart_tolerance, int monitor_every, int order, const std::string& composition,
                    const std::string& rotation) {
          RattleOptions o;
          o.h = h;
          o.min_pivot_ratio = min_pivot_ratio;
          o.hitch = hitch_mode_from_string(hitch);
          o.gap_tolerance = gap_tolerance;
          o.gap_tolerance_limit = gap_tolerance_limit;
          o.max_gap_iterations = max_gap_iterations;
          set_restart(o.restart, restart);
          o.restart.tolerance = restart_tolerance;
          o.restart.monitor_every = monitor_every;
          o.order = order;
          o.composition = composition_from_string(composition);
          o.rotation = rotation_from_string(rotation);
          validate(o);
          return o;
        }),
        py::arg("h") = d.h, py::kw_only(), py::arg("min_pivot_ratio") = d.min_pivot_ratio,
        py::arg("hitch") = to_string(d.hitch), py::arg("gap_tolerance") = d.gap_tolerance,
        py::arg("gap_tolerance_limit") = d.gap_tolerance_limit, py::arg("max_gap_iterations") = d.max_gap_iterations,
        py::arg("restart") = restart_spec(d.restart), py::arg("restart_tolerance") = d.restart.tolerance,
        py::arg("monitor_every") = d.restart.monitor_every, py::arg("order") = d.order,
        py::arg("composition") = to_string(d.composition), py::arg("rotation") = to_string(d.rotation));

  // A validated attribute: changed on a copy, checked whole, then kept.
}

// The fields, each checked on assignment together with the others.
void rattle_fields(py::class_<RattleOptions>& c) {
  auto field = [&c](const char* name, auto get, auto set, const char* doc) {
    using T = decltype(get(std::declval<const RattleOptions&>()));
    c.def_property(name, get, [set](RattleOptions& o, T value) {
      RattleOptions changed = o;
      set(changed, value);
      validate(changed);
      o = changed;
    }, doc);
  };
  field("h", [](const RattleOptions& o) { return o.h; }, [](RattleOptions& o, double v) { o.h = v; },
        "The time step (with order 4, 6 or 8, the composed step's size H).");
  field("min_pivot_ratio", [](const RattleOptions& o) { return o.min_pivot_ratio; },
        [](RattleOptions& o, double v) { o.min_pivot_ratio = v; },
        "The smallest accepted pivot of C relative to its diagonal (the squared sine of the angle "
        "between a one-form and the span of the others); below it the step refuses "
        "(Status.NearlyDependentOneForms): nearly dependent one-forms would make lambda meaningless.");
  field("hitch", [](const RattleOptions& o) { return std::string(to_string(o.hitch)); },
        [](RattleOptions& o, const std::string& v) { o.hitch = hitch_mode_from_string(v); },
        "How the holonomic rows (hitches) are treated: 'holonomic' (g(q_{k+1}) = 0 enforced at position "
        "level, as RATTLE does) or 'oneform' (plain one-forms, the paper's method).");
  field("gap_tolerance", [](const RattleOptions& o) { return o.gap_tolerance; },
        [](RattleOptions& o, double v) { o.gap_tolerance = v; },
        "Holonomic mode (hitch 'holonomic'): the position-level corrections iterate until "
        "max ``|g_j(q_{k+1})|`` <= gap_tolerance (raised to 16 eps max ``|q|`` when round-off alone exceeds it, up to "
        "gap_tolerance_limit).");
  field("gap_tolerance_limit", [](const RattleOptions& o) { return o.gap_tolerance_limit; },
        [](RattleOptions& o, double v) { o.gap_tolerance_limit = v; },
        "Holonomic mode (hitch 'holonomic'): the most gap_tolerance is raised to for large coordinates "
        "(at ``|q|`` ~ 1e19 round-off is 3e4); a step that cannot close the gaps to it fails with "
        "Status.GapNotConverged.");
  field("max_gap_iterations", [](const RattleOptions& o) { return o.max_gap_iterations; },
        [](RattleOptions& o, int v) { o.max_gap_iterations = v; },
        "Holonomic mode (hitch 'holonomic'): the position-level corrections a step may take before it "
        "fails with Status.GapNotConverged.");
  field("restart", [](const RattleOptions& o) { return restart_spec(o.restart); },
        [](RattleOptions& o, const std::string& v) { set_restart(o.restart, v); },
        "When the multipliers are restarted against the period-2 mode: 'auto' (when the measured "
        "parasitic amplitude exceeds restart_tolerance), '0' (never: the paper's plain method) or a "
        "whole number K (every K steps).");
  field("restart_tolerance", [](const RattleOptions& o) { return o.restart.tolerance; },
        [](RattleOptions& o, double v) { o.restart.tolerance = v; },
        "restart 'auto': restart when the parasitic amplitude (h/2) "
        "``|lambda~ - lambda_s|_C / |p~|_{M^-1}`` (dimensionless) exceeds this; 0: h^3 (h in the "
        "model's time unit, never below the amplitude's round-off), 1e-3 from h = 0.1 on.");
  field("monitor_every", [](const RattleOptions& o) { return o.restart.monitor_every; },
        [](RattleOptions& o, int v) { o.restart.monitor_every = v; },
        "Measure the parasitic amplitude at least every this many steps, in every restart mode "
        "(0: never; restart 'auto' needs at least 1).");
  field("order", [](const RattleOptions& o) { return o.order; }, [](RattleOptions& o, int v) { o.order = v; },
        "2 (the plain step of size h), or 4, 6 or 8: one step advances by h through a palindromic "
        "composition of plain substeps (see composition).");
  field("composition", [](const RattleOptions& o) { return std::string(to_string(o.composition)); },
        [](RattleOptions& o, const std::string& v) { o.composition = composition_from_string(v); },
        "The composition of orders 4, 6 and 8 (names in the class's text); 'auto': blanes-moan4, "
        "blanes-moan6 or kahan-li17 for the order (none for order 2).");
  field("rotation", [](const RattleOptions& o) { return std::string(to_string(o.rotation)); },
        [](RattleOptions& o, const std::string& v) { o.rotation = rotation_from_string(v); },
        "Models with 3-D rigid bodies: the rotation's discrete Lagrangian, 'moser-veselov' (energy exact "
        "for any inertia), 'moser-veselov-f' (also exact on an isotropic body's free rotation) or "
        "'exponential' (for comparison: its energy drifts for a non-isotropic body).");
}

}  // namespace

void bind_options(py::module_& m) {
  py::class_<RattleOptions> c(m, "RattleOptions", R"(Options of the explicit step (core/include/nonholo/rattle_options.hpp).

All but h are keyword arguments. Invalid values raise ValueError with the library's message,
in the constructor and on assignment to an attribute (an assignment is checked together with
the other fields, so set `order` before a `composition` of that order). hitch is 'holonomic'
or 'oneform'; restart is 'auto', '0' (never) or a number of steps K; composition is 'auto',
'triple-jump', 'suzuki5', 'blanes-moan4' (order 4), 'yoshida7', 'kahan-li9', 'blanes-moan6'
(order 6), 'mclachlan15' or 'kahan-li17' (order 8); rotation (models with 3-D
rigid bodies: the rotation's discrete Lagrangian) is 'moser-veselov', 'moser-veselov-f' or
'exponential'.)");
  rattle_constructor(c);
  rattle_fields(c);
  c.def("__repr__", [](const RattleOptions& o) {
    std::ostringstream os;
    os << "RattleOptions(h=" << num(o.h) << ", min_pivot_ratio=" << num(o.min_pivot_ratio) << ", hitch='"
       << to_string(o.hitch) << "', gap_tolerance=" << num(o.gap_tolerance)
       << ", gap_tolerance_limit=" << num(o.gap_tolerance_limit) << ", max_gap_iterations=" << o.max_gap_iterations
       << ", restart='" << restart_spec(o.restart) << "', restart_tolerance=" << num(o.restart.tolerance)
       << ", monitor_every=" << o.restart.monitor_every << ", order=" << o.order << ", composition='"
       << to_string(o.composition) << "', rotation='" << to_string(o.rotation) << "')";
    return os.str();
  });
}

}  // namespace nonholo::python
