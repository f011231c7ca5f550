#pragma once
/// @file
/// The built-in scenes: each turns a set of parameters into a Model and an initial
/// configuration with a velocity guess (projected onto D at start-up). q0 has the model's n_q
/// entries, v0 its n_v.
#include <nonholo/model.hpp>
#include <nonholo/scenarios/parameters.hpp>

#include <functional>
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// A scene built for a set of parameters.
struct SceneSetup {
  Model model;  ///< the system
  double t0 = 0.0;  ///< the start time
  Vector q0;  ///< n_q entries
  Vector v0;  ///< velocity guess, n_v entries
};

/// A scene: its name, parameters and defaults, and how to build it.
struct SceneInfo {
  std::string name;  ///< as `nonholo run NAME` takes it
  std::string description;  ///< one line for `nonholo list`
  std::vector<ParameterSpec> parameters;  ///< what `--set` may change
  double default_dt;  ///< the step size unless `--dt`
  double default_t_end;  ///< the end time unless `--t-end`
  std::function<SceneSetup(const Parameters&)> build;  ///< the model and start for these parameters

  Parameters defaults() const { return Parameters(name, parameters); }  ///< the parameters at their defaults
};

/// The built-in scenes.
///@{
SceneInfo particle_scene();  ///< nonholonomic particle in R^3, M = I, constraint zdot - y xdot = 0
SceneInfo sleigh_scene();  ///< Chaplygin sleigh, centre-of-mass coordinates, blade a behind the centre
SceneInfo sleigh_contact_scene();  ///< the sleigh in contact-point coordinates (metric M(theta): implicit)
SceneInfo snakeboard_scene();  ///< snakeboard (board, rotor, coupled axles), optional sinusoidal controls
SceneInfo sleigh_chain_scene();  ///< N Chaplygin sleighs hitched in a chain, optional torsional springs
SceneInfo wheeled_train_scene();  ///< generated N-body wheeled train, seeded per-body parameters, driven lead
///@}
/// 3-D rigid bodies (README "3-D bodies"): q holds quaternions, v0 body-frame angular velocities.
///@{
SceneInfo suslov_scene();  ///< Suslov top: about a fixed point, no angular velocity along a body axis
SceneInfo veselova_scene();  ///< Veselova top: about a fixed point, no spin about the vertical
SceneInfo chaplygin_ball_scene();  ///< a ball of any inertia rolling without slipping on a plane
SceneInfo ball_chain_scene();  ///< rolling balls whose centres are joined by rods in a chain
SceneInfo rolling_disk_scene();  ///< thin disk rolling without slipping on a plane under gravity
///@}

/// Every built-in scene, in the order `nonholo list` shows them.
const std::vector<SceneInfo>& scene_catalogue();
/// The built-in scene of this name.
/// Throws std::invalid_argument listing the known scenes.
const SceneInfo& find_scene(const std::string& name);

}  // namespace nonholo::scenarios
