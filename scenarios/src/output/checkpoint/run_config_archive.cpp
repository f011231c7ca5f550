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

}  // namespace nonholo::scenarios
