#pragma once
// The built-in scenes: each turns a set of parameters into a Model and an initial
// configuration with a velocity guess (projected onto D at start-up). q0 has the model's n_q
// entries, v0 its n_v.
#include <nonholo/model.hpp>
#include <nonholo/scenarios/parameters.hpp>

#include <functional>
#include <string>
#include <vector>

namespace nonholo::scenarios {

struct SceneSetup {
  Model model;
  double t0 = 0.0;
  Vector q0;  // n_q entries
  Vector v0;  // velocity guess, n_v entries
};

struct SceneInfo {
  std::string name;
  std::string description;
  std::vector<ParameterSpec> parameters;
  double default_dt;
  double default_t_end;
  std::function<SceneSetup(const Parameters&)> build;

  Parameters defaults() const { return Parameters(name, parameters); }
};

SceneInfo particle_scene();
SceneInfo sleigh_scene();
SceneInfo sleigh_contact_scene();
SceneInfo snakeboard_scene();
SceneInfo sleigh_chain_scene();
SceneInfo wheeled_train_scene();
// 3-D rigid bodies (README "3-D bodies"): q holds quaternions, v0 body-frame angular velocities.
SceneInfo suslov_scene();
SceneInfo veselova_scene();
SceneInfo chaplygin_ball_scene();
SceneInfo ball_chain_scene();
SceneInfo rolling_disk_scene();

const std::vector<SceneInfo>& scene_catalogue();
// Throws std::invalid_argument listing the known scenes.
const SceneInfo& find_scene(const std::string& name);

}  // namespace nonholo::scenarios
