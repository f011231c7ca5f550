// Scene files (<nonholo/scenarios/scene_file.hpp>): a JSON file read into a System
// (file/read_system.cpp) and built into a model for each run (file/build_system.cpp).
#include <nonholo/scenarios/scene_file.hpp>

#include <memory>
#include <string>

#include "scenes/file/document.hpp"
#include "scenes/file/system.hpp"

namespace nonholo::scenarios {

bool is_scene_file(const std::string& name) {
  return name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0;
}

SceneInfo load_scene_file(const std::string& path) {
  return parse_scene_text(scene_file::read_file(path), path);
}

SceneInfo parse_scene_text(const std::string& text, const std::string& path) {
  auto system = std::make_shared<scene_file::System>(scene_file::read_system(text, path));
  SceneInfo info;
  info.name = path;
  info.description = "scene file " + path;
  info.default_dt = system->dt;
  info.default_t_end = system->t_end;
  info.build = [system](const Parameters&) { return scene_file::build_system(*system); };
  return info;
}

}  // namespace nonholo::scenarios
