// RunConfig to and from checkpoint bytes (run_config_archive.hpp).
#include "output/checkpoint/run_config_archive.hpp"

#include <nonholo/scenarios/scene_file.hpp>

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

// Every field that shapes the run, in one order (both directions).
template <class Archive, class Config, class Text>
void fields(Archive& a, Config& c, Text& scene_text) {
  a.tag("run-config");
  a(c.scene), a(scene_text);
  long n = static_cast<long>(c.assignments.size());
  a(n);
  c.assignments.resize(static_cast<std::size_t>(n));
  for (auto& s : c.assignments) a(s);
  a(c.dt), a(c.t_end), a(c.csv_path), a(c.every);
  int backend = static_cast<int>(c.backend), hitch = static_cast<int>(c.hitch);
  a(backend), a(hitch);
  c.backend = static_cast<sparse::Backend>(backend);
  c.hitch = static_cast<HitchMode>(hitch);
  a(c.restart), a(c.restart_tol), a(c.monitor_every), a(c.method), a(c.order), a(c.composition), a(c.rotation);
  a(c.error_estimate), a(c.accuracy), a(c.accuracy_check), a(c.project), a(c.tol), a(c.adaptive), a(c.horizon);
  a(c.threads);
  long conditions = static_cast<long>(c.stop_when.size());
  a(conditions);
  c.stop_when.resize(static_cast<std::size_t>(conditions));
  for (auto& s : c.stop_when) a(s);
}

}  // namespace

void save(OutArchive& a, const RunConfig& config) {
  RunConfig copy = config;  // fields() takes both directions through one signature
  std::string text = is_scene_file(config.scene) ? file_text(config.scene) : std::string();
  fields(a, copy, text);
}

void load(InArchive& a, RunConfig& config) {
  std::string text;
  fields(a, config, text);
  if (is_scene_file(config.scene) && file_text(config.scene) != text)
    throw std::runtime_error("the scene file " + config.scene +
                             " has changed (or gone) since the checkpoint was written: restore it to resume");
}

void save(OutArchive& a, bool from_code, const RunStart& start, const std::string& fingerprint) {
  a.tag("source");
  a(from_code), a(fingerprint);
  if (!from_code) return;
  a(start.t0), a(start.q0), a(start.v0), a(start.state.has_value());
  if (start.state) save(a, *start.state);
}

void load(InArchive& a, RunSource& source) {
  a.tag("source");
  a(source.from_code), a(source.fingerprint);
  source.start = RunStart{};
  if (!source.from_code) return;
  bool has_state = false;
  a(source.start.t0);
  a.resize_into(source.start.q0);
  a.resize_into(source.start.v0);
  a(has_state);
  if (has_state) load(a, source.start.state.emplace());
}

}  // namespace nonholo::scenarios
