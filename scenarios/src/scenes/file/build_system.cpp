// A System's model (system.hpp), in phases: its bodies, its elements' rows body by body, its
// couplings and forces, the model built, then the initial state from the file's values.
#include <nonholo/model_builder.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "scenes/file/reader.hpp"
#include "scenes/file/system.hpp"

namespace nonholo::scenarios::scene_file {
namespace {

// The builder's own checks, prefixed with the file and the element's path.
template <class Add>
void in(const System& s, const std::string& where, const Add& add) {
  try {
    add();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(shown(s.file + ": " + where + ": " + e.what()));
  }
}

void add_bodies(const System& s, ModelBuilder& b) {
  const int n = static_cast<int>(s.bodies.size());
  for (int i = 0; i < n; ++i) {
    const Body& body = s.bodies[static_cast<std::size_t>(i)];
    const std::string k = std::to_string(i);
    if (!body.rigid) {
      in(s, "bodies[" + k + "]", [&] { b.add_planar_body({"x" + k, "y" + k, "theta" + k}, body.mass, body.inertia); });
      continue;
    }
    // Coordinates qw<i>, ..., z<i> by the body's index (as x<i> for a planar body); a name in
    // the file is only a comment.
    try {
      b.add_rigid_body(body.shape);
    } catch (const std::invalid_argument& e) {
      // The inertia alone refused (not symmetric, not positive definite, ill-conditioned), or
      // only with the mass (their ratio)?
      RigidBody alone;
      alone.inertia = body.shape.inertia;
      alone.any_inertia = body.shape.any_inertia;
      bool inertia = false;
      try {
        ModelBuilder().add_rigid_body(alone);
      } catch (const std::invalid_argument&) {
        inertia = true;
      }
      throw std::invalid_argument(shown(s.file + ": bodies[" + k + "]" + (inertia ? ".inertia" : "") + ": " + e.what()));
    }
  }
}

void add_constraints(const System& s, ModelBuilder& b) {
  const int n = static_cast<int>(s.bodies.size());
  // Local elements (nonholo/elements.hpp), their rows body by body (the one-body constraints of
  // body b, then those joining b to a later body) whatever the file's order: a chain written
  // in any order is streamed by the fused step (docs/design.md section 7). Each row is labelled with
  // its element of the file, for the messages of the set-up and of failed steps ("pivot of row
  // 7 of C (constraints[3] (knife_edge on body 2)) ...").
  std::vector<std::vector<const Constraint*>> of_body(static_cast<std::size_t>(n)), joining(static_cast<std::size_t>(n));
  for (const Constraint& c : s.constraints)
    (c.joins_two() ? joining[static_cast<std::size_t>(std::min(c.a, c.b))] : of_body[static_cast<std::size_t>(c.a)])
        .push_back(&c);
  const auto add = [&](const Constraint& c) {
    const std::string where = "constraints[" + std::to_string(c.index) + "]";
    const std::string label = where + " (" + c.label + ")";
    in(s, where, [&] {
      switch (c.kind) {
        case Constraint::kKnife: b.add_knife_edge({c.a, c.p}, label); break;
        case Constraint::kHitch: b.add_hitch({c.a, c.b, c.p, c.p2}, label); break;
        case Constraint::kBodyAxis: b.add_body_axis_constraint({c.a, c.axis}, label); break;
        case Constraint::kSpaceAxis: b.add_space_axis_constraint({c.a, c.axis}, label); break;
        case Constraint::kBall: b.add_rolling_ball({c.a, c.p}, label); break;
        case Constraint::kDisk: b.add_rolling_disk({c.a, c.p}, label); break;
        case Constraint::kRod: b.add_rod({c.a, c.b, c.p}, label); break;
      }
    });
  };
  for (int body = 0; body < n; ++body) {
    for (const Constraint* c : of_body[static_cast<std::size_t>(body)]) add(*c);
    for (const Constraint* c : joining[static_cast<std::size_t>(body)]) add(*c);
  }
}

void add_couplings_and_forces(const System& s, ModelBuilder& b) {
  for (const Spring& sp : s.springs)
    in(s, "couplings[" + std::to_string(sp.index) + "]", [&] { b.add_torsional_spring({sp.a, sp.b, sp.stiffness, sp.rest}); });
  for (const Drive& d : s.drives) {
    in(s, "forces[" + std::to_string(d.index) + "]", [&] {
      const TimeFunction u = [d](double t) { return d.at(t); };
      const TimeVector v = [d](double t) { return d.vector_at(t); };
      switch (d.kind) {
        case Drive::kThrust: b.add_thrust({d.body, u, nullptr}); break;
        case Drive::kTorque: b.add_thrust({d.body, nullptr, u}); break;
        case Drive::kBodyTorque: b.add_body_torque({d.body, v}); break;
        case Drive::kBodyForce: b.add_body_force({d.body, v}); break;
        case Drive::kGravity: b.add_gravity(d.value[0]); break;
      }
    });
  }
}

Model build_model(const System& s, ModelBuilder& b) {
  try {
    return std::move(b).build();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(shown(s.file + ": " + e.what()));
  }
}

// q0 and v0 from the bodies' positions, headings, orientations and velocities.
SceneSetup initial_state(const System& s, Model model) {
  const int n = static_cast<int>(s.bodies.size());
  const int nq = model.num_configuration(), nv = model.num_velocities();
  SceneSetup setup{std::move(model), 0.0, Vector::Zero(nq), Vector::Zero(nv)};
  for (int i = 0; i < n; ++i) {
    const Body& body = s.bodies[static_cast<std::size_t>(i)];
    const auto& layout = setup.model.body(i);
    if (!body.rigid) {
      setup.q0.segment<3>(layout.q_offset) << body.x, body.y, body.heading;
      setup.v0.segment<3>(layout.offset) << body.vx, body.vy, body.turn_rate;
      continue;
    }
    setup.q0.segment<4>(layout.q_offset) = body.orientation;
    setup.v0.segment<3>(layout.offset) = body.angular_velocity;
    for (std::size_t j = 0; j < body.position.size(); ++j) {
      setup.q0[layout.q_offset + 4 + static_cast<int>(j)] = body.position[j];
      setup.v0[layout.offset + 3 + static_cast<int>(j)] = body.velocity[j];
    }
  }
  return setup;
}

}  // namespace

SceneSetup build_system(const System& s) {
  ModelBuilder b;
  add_bodies(s, b);
  add_constraints(s, b);
  add_couplings_and_forces(s, b);
  return initial_state(s, build_model(s, b));
}

}  // namespace nonholo::scenarios::scene_file
