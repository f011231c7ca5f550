// A batch row to and from bytes (batch_row.hpp): every RunSummary field in one order, then the row's values
// and final state; the same fields are a summary's checkpoint.
#include "output/batch_row.hpp"

#include <algorithm>
#include <stdexcept>
#include <type_traits>

namespace nonholo::scenarios {
namespace {

// A field added to RunSummary must be added to fields() below, or MPI batches would lose it:
// this fails to compile until then (the size on x86-64 Linux, libstdc++).
static_assert(sizeof(void*) != 8 || sizeof(RunSummary) == 672,
              "RunSummary changed: add the new field to fields() in batch_row.cpp, then update this size");

// Every field of RunSummary, in one order for both directions.
template <class Archive, class Summary>
void fields(Archive& a, Summary& s) {
  a(s.scene), a(s.method), a(s.backend), a(s.hitch), a(s.restart), a(s.order), a(s.composition), a(s.bodies);
  a(s.status), a(s.message), a(s.steps), a(s.dt), a(s.t_final), a(s.wall_s), a(s.ns_per_step);
  a(s.ns_per_body_step), a(s.energy_rel_err_max), a(s.energy_post_rel_err_max), a(s.residual_max), a(s.gap_max);
  a(s.residual_rel_max);
  a(s.restarts), a(s.parasitic_max), a(s.has_work), a(s.work), a(s.energy_balance_err_max), a(s.warning);
  a(s.rhs_evaluations), a(s.factorizations), a(s.error_estimate), a(s.extent), a(s.accuracy), a(s.stability_ratio);
  a(s.tol), a(s.adaptive_steps), a(s.rejected);
  a(s.has_momentum), a(s.has_error_estimate);
  a(s.momentum_drift_max), a(s.rotation), a(s.legendre_iterations_max), a(s.threads);
  a(s.threads_note), a(s.setup_s), a(s.accuracy_check), a(s.stopped_by), a(s.t_stop);
  long warnings = static_cast<long>(s.warnings.size());
  a(warnings);
  if constexpr (std::is_const_v<Summary>) {
    for (const auto& w : s.warnings) a(static_cast<int>(w.kind)), a(w.text);
  } else {
    s.warnings.resize(static_cast<std::size_t>(warnings));
    for (auto& w : s.warnings) {
      int kind = 0;
      a(kind), a(w.text);
      w.kind = static_cast<WarningKind>(kind);
    }
  }
}

}  // namespace

void save(OutArchive& a, const RunSummary& summary) { fields(a, summary); }
void load(InArchive& a, RunSummary& summary) { fields(a, summary); }

std::string pack_row(const Row& row, bool whole_state) {
  OutArchive w;
  fields(w, row.summary);
  w(row.values);
  const auto shown = whole_state ? row.final_q.size() : std::min<Eigen::Index>(3, row.final_q.size());
  w(row.final_q.head(shown));
  w(row.names);
  w(row.error);
  w(whole_state);
  if (whole_state) {
    w(row.final_p);
    w(row.coordinates);
    w(row.velocities);
  }
  return w.bytes();
}

Row unpack_row(const std::string& bytes) {
  InArchive r(bytes, "batch row");
  Row row;
  fields(r, row.summary);
  r(row.values);
  r.resize_into(row.final_q);
  r(row.names);
  r(row.error);
  bool whole_state = false;
  r(whole_state);
  if (whole_state) {
    r.resize_into(row.final_p);
    r(row.coordinates);
    r(row.velocities);
  }
  if (!r.done()) throw std::logic_error("batch row: trailing bytes");
  return row;
}

}  // namespace nonholo::scenarios
