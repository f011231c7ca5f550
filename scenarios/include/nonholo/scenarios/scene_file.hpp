#pragma once
// Scene files: `nonholo run FILE.json` builds a planar multibody system from a small
// catalogue instead of a built-in scene.
//
//   {
//     "dt": 0.01, "t_end": 10,                                  (optional)
//     "bodies": [ {"name": "lead", "mass": 1, "inertia": 1,
//                  "position": [0, 0], "heading": 0,            (default 0)
//                  "velocity": [1, 0], "turn_rate": 0.5}, ...], (guess; default 0)
//     "constraints": [ {"type": "knife_edge", "body": 0, "offset": 0.2},
//                      {"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5}, ...],
//     "couplings":   [ {"type": "torsional_spring", "bodies": [0, 1], "stiffness": 1,
//                       "rest_angle": 0}, ...],
//     "forces":      [ {"type": "thrust" | "torque", "body": 0, "value": 0,
//                       "amplitude": 1, "omega": 1, "phase": 0}, ...]
//   }
//
// Body i has coordinates x<i>, y<i>, theta<i>; a knife edge sits `offset` behind the centre;
// a hitch joins the point `rear` behind body a's centre to the point `front` ahead of body
// b's centre (a holonomic constraint, closed at the start); a spring pulls theta_a - theta_b
// towards rest_angle; a thrust acts along the body's heading, a torque on its angle, both
// value + amplitude sin(omega t + phase).
//
// Limits, checked before the text is parsed: a scene file is a regular file (not a
// directory, device or pipe) of at most kMaxSceneFileBytes, nested at most kMaxSceneDepth
// arrays and objects deep (the format itself needs 4). A key given twice in one object is
// refused, not silently overwritten. Problems found later, when the model is built or the
// run starts, name the element of the file: each constraint row carries the label
// "constraints[i] (knife_edge on body b)" or "constraints[i] (hitch of bodies a and b, x)".
#include <nonholo/scenarios/scene.hpp>

#include <cstddef>
#include <string>

namespace nonholo::scenarios {

inline constexpr std::size_t kMaxSceneFileBytes = std::size_t{64} << 20;  // 64 MiB
inline constexpr int kMaxSceneDepth = 64;

// True when `name` should be read as a scene file (it ends in .json).
bool is_scene_file(const std::string& name);

// Reads and checks the file; the SceneInfo takes no parameters. Every error is a
// std::invalid_argument naming the file, the position (line and column for syntax, the
// path such as bodies[1].mass otherwise) and the problem.
SceneInfo load_scene_file(const std::string& path);

// The same from the text of a scene file (no file is read; `name` stands for the file in
// messages and in SceneInfo::name). Throws std::invalid_argument only, for any text: the
// fuzz target tests/fuzz/fuzz_scene_file.cpp holds it to that.
SceneInfo parse_scene_text(const std::string& text, const std::string& name);

}  // namespace nonholo::scenarios
