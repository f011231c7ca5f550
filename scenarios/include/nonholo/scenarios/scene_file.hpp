#pragma once
/// @file
/// Scene files: `nonholo run FILE.json` builds a multibody system of planar bodies and 3-D
/// rigid bodies from a small catalogue instead of a built-in scene.
///
/// ~~~{.unparsed}
///   {
///     "dt": 0.01, "t_end": 10,                                  (optional)
///     "bodies": [ {"name": "lead", "mass": 1, "inertia": 1,     (planar, the default type)
///                  "position": [0, 0], "heading": 0,            (default 0)
///                  "velocity": [1, 0], "turn_rate": 0.5},       (guess; default 0)
///                 {"type": "rigid", "name": "top",              (a 3-D rigid body)
///                  "mass": 1,                                   (default 1 if translation 0)
///                  "inertia": [0.3, 0.4, 0.5] | [[...], [...], [...]],
///                  "translation": 0 | 2 | 3,                    (default 0)
///                  "orientation": [w, x, y, z] | {"axis": [x, y, z], "angle": a},
///                                                               (default [1, 0, 0, 0])
///                  "position": [x, y(, z)],                     (d numbers; required if d > 0)
///                  "angular_velocity": [wx, wy, wz],            (body frame; guess; default 0)
///                  "velocity": [vx, vy(, vz)]}, ...],           (d numbers; guess; default 0)
///     "constraints": [ {"type": "knife_edge", "body": 0, "offset": 0.2},
///                      {"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5},
///                      {"type": "body_axis", "body": 2, "axis": [0, 0, 1]},
///                      {"type": "space_axis", "body": 2, "axis": [0, 0, 1]},  (default e3)
///                      {"type": "rolling_ball" | "rolling_disk", "body": 2, "radius": 1},
///                      {"type": "rod", "bodies": [2, 3], "length": 1}, ...],
///     "couplings":   [ {"type": "torsional_spring", "bodies": [0, 1], "stiffness": 1,
///                       "rest_angle": 0}, ...],
///     "forces":      [ {"type": "thrust" | "torque", "body": 0, "value": 0,
///                       "amplitude": 1, "omega": 1, "phase": 0},
///                      {"type": "gravity", "g": 9.81},                        (default 9.81)
///                      {"type": "body_torque" | "body_force", "body": 2, "value": [0, 0, 0],
///                       "amplitude": [0, 0, 1], "omega": 1, "phase": 0}, ...]
///   }
/// ~~~
///
/// Planar bodies: body i has coordinates `x<i>`, `y<i>`, `theta<i>`; a knife edge sits `offset`
/// behind the centre; a hitch joins the point `rear` behind body a's centre to the point
/// `front` ahead of body b's centre (a holonomic constraint, closed at the start); a spring
/// pulls theta_a - theta_b towards rest_angle; a thrust acts along the body's heading, a torque
/// on its angle, both value + amplitude sin(omega t + phase).
///
/// Rigid bodies (nonholo/rigid_body.hpp): body i has configuration `qw<i>`, `qx<i>`, `qy<i>`, `qz<i>`
/// (its orientation R) and its centre `x<i>`, `y<i>`(, `z<i>`), d = "translation" entries (0: a
/// fixed point, 2: the centre moves in the horizontal plane, 3: free); its velocity is the
/// angular velocity in the body frame, then the centre's velocity in space. Coordinates are
/// named by the body's index, as for planar bodies ("name" is a comment). "inertia" is the
/// central inertia in the body frame: 3 principal moments or a symmetric positive definite
/// 3x3 array. A quaternion orientation must have norm within 1e-6 of 1 (it is normalised);
/// an axis (any nonzero length) and an angle in radians give the rotation about that axis.
/// "mass" is required when d > 0, and so is "position" (it fixes where the body stands: the
/// rolling and rod checks below need it); "position" and "velocity" are refused when d = 0.
/// Keys of the other type of body are refused, saying which type they belong to.
/// Constraints on rigid bodies (nonholo/elements.hpp): body_axis keeps Omega normal to an
/// axis fixed in the body (the Suslov problem), space_axis normal to an axis fixed in space
/// (Veselova); rolling_ball rolls a ball of radius r (translation 2 or 3) without slipping on
/// z = 0, rolling_disk a thin disk whose axis is the body's e3 (translation 3); a rod holds two
/// centres (planar bodies, or rigid bodies with the same translation 2 or 3) `length` apart.
/// Holonomic constraints must hold at the start: a rod's centres `length` apart, a ball with
/// translation 3 at height z = radius, a disk at z = radius sqrt(1 - n_z^2) with n = R e3 its
/// axis (a disk lying flat, n vertical, has no contact point and is refused); the message
/// gives the value to set. Gravity pulls every rigid body with translation 3 along -z (a file
/// with gravity needs one); a body torque acts in the body frame, a body force on the centre
/// in space, each component value + amplitude sin(omega t + phase). Elements on the wrong kind
/// of body or translation are refused with the element's own message.
///
/// Limits, checked before the text is parsed: a scene file is a regular file (not a
/// directory, device or pipe) of at most kMaxSceneFileBytes, nested at most kMaxSceneDepth
/// arrays and objects deep (the format itself needs 5: a 3x3 inertia in a body in
/// "bodies"). A key given twice in one object is refused, not silently overwritten. Problems
/// found later, when the model is built or the run starts, name the element of the file: each
/// constraint row carries the label "constraints[i] (knife_edge on body b)", "constraints[i]
/// (hitch of bodies a and b, x)", "constraints[i] (rolling_ball on body b, height)",
/// "constraints[i] (rod of bodies a and b)" and so on, and the builder's refusals of a body or
/// an element are prefixed with its path ("bodies[1].inertia: rigid body 1: inertia is not
/// positive definite ...").
#include <nonholo/scenarios/scene.hpp>

#include <cstddef>
#include <string>

namespace nonholo::scenarios {

inline constexpr std::size_t kMaxSceneFileBytes = std::size_t{64} << 20;  ///< 64 MiB
inline constexpr int kMaxSceneDepth = 64;  ///< arrays and objects nested at most this deep

/// True when `name` should be read as a scene file (it ends in .json).
bool is_scene_file(const std::string& name);

/// Reads and checks the file; the SceneInfo takes no parameters. Every error is a
/// std::invalid_argument naming the file, the position (line and column for syntax, the
/// path such as bodies[1].mass otherwise) and the problem.
SceneInfo load_scene_file(const std::string& path);

/// The same from the text of a scene file (no file is read; `name` stands for the file in
/// messages and in SceneInfo::name). Throws std::invalid_argument only, for any text: the
/// fuzz target tests/fuzz/fuzz_scene_file.cpp holds it to that.
SceneInfo parse_scene_text(const std::string& text, const std::string& name);

}  // namespace nonholo::scenarios
