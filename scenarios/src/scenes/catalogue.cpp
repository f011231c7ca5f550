// The built-in scenes in one list (scene.hpp): scene_catalogue, and find_scene by name.
#include <nonholo/scenarios/scene.hpp>

#include <stdexcept>

namespace nonholo::scenarios {

const std::vector<SceneInfo>& scene_catalogue() {
  static const std::vector<SceneInfo> scenes{particle_scene(), sleigh_scene(), sleigh_contact_scene(),
                                               snakeboard_scene(),
                                               sleigh_chain_scene(), wheeled_train_scene(),
                                               suslov_scene(), veselova_scene(), chaplygin_ball_scene(),
                                               ball_chain_scene(), rolling_disk_scene()};
  return scenes;
}

const SceneInfo& find_scene(const std::string& name) {
  for (const auto& s : scene_catalogue())
    if (s.name == name) return s;
  std::string known;
  for (const auto& s : scene_catalogue()) known += (known.empty() ? "" : ", ") + s.name;
  throw std::invalid_argument("unknown scene '" + name + "' (known: " + known + ")");
}

}  // namespace nonholo::scenarios
