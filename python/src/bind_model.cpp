// The model in Python: ModelBuilder (bodies, elements, callbacks that are Python callables or
// constants), Model and the quaternion helpers of rigid bodies. A builder given a Python callable
// makes models that call Python (Model.calls_python: the step then keeps the GIL).
#include "bind_common.hpp"

namespace nonholo::python {
namespace {

// A Python callable for the builder, which from now on makes models that call Python.
py::object callable(PyBuilder& b, py::object f) {
  if (!PyCallable_Check(f.ptr())) throw py::type_error("expected a callable, got " + callback_detail::type_name(f));
  b.calls_python = true;
  return f;
}

// A thrust's force or torque: None, a number (no Python at step time) or a callable of t.
TimeFunction time_function(PyBuilder& b, const py::object& f, const char* name) {
  if (f.is_none()) return {};
  if (!PyCallable_Check(f.ptr())) {
    try {
      return [value = f.cast<double>()](double) { return value; };
    } catch (const py::cast_error&) {
      throw py::type_error(std::string("add_thrust: ") + name + " must be None, a number or a callable of t, got " +
                           callback_detail::type_name(f));
    }
  }
  return time_callback(std::string("thrust ") + name + "(t)", callable(b, f));
}

// A rigid body's inertia: a 3x3 matrix, its 3 principal moments (a diagonal inertia) or one
// number J (the isotropic J Id). The builder checks the values (SPD, conditioning).
Eigen::Matrix3d inertia_of(const py::object& inertia) {
  auto a = Array::ensure(inertia);
  if (!a) {
    PyErr_Clear();
    throw py::value_error("add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got " +
                          callback_detail::type_name(inertia));
  }
  const double* x = a.data();
  if (a.ndim() == 0) return x[0] * Eigen::Matrix3d::Identity();
  if (a.ndim() == 1 && a.size() == 3) return Eigen::Vector3d(x[0], x[1], x[2]).asDiagonal();
  if (a.ndim() == 2 && a.shape(0) == 3 && a.shape(1) == 3)
    return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(x);
  std::string shape = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  shape += a.ndim() == 1 ? ",)" : ")";
  throw py::value_error("add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got an "
                        "array of shape " + shape);
}

// A body torque's or force's function: a callable of t returning 3 numbers, or 3 numbers (a
// constant: no Python at step time).
TimeVector time_vector(PyBuilder& b, const py::object& f, const char* element, const char* what, int body,
                       const char* expected) {
  if (f.is_none())
    throw py::type_error(std::string("add_") + element + ": " + what +
                         " must be a callable of t or 3 numbers, got None");
  if (!PyCallable_Check(f.ptr())) {
    const Eigen::Vector3d value = vector3(f, std::string("add_") + element + ": " + what);
    return [value](double) { return value; };
  }
  return time_vector_callback(std::string(what) + "(t) of body " + std::to_string(body), expected, callable(b, f));
}

// Runs add(); a call the builder refuses leaves calls_python as it was (its callable is not kept).
template <class Add>
void unless_refused(PyBuilder& b, Add&& add) {
  const bool before = b.calls_python;
  try {
    add();
  } catch (...) {
    b.calls_python = before;
    throw;
  }
}

}  // namespace

namespace {

// The bodies: general, planar and rigid, and room reserved for them.
void builder_bodies(py::class_<PyBuilder>& c) {
  c.def(py::init<>())
      .def("add_body", [](PyBuilder& b, const std::vector<std::string>& names, const Eigen::MatrixXd& mass_block) {
            return b.builder.add_body(names, mass_block);
          }, py::arg("names"), py::arg("mass_block"),
          "A body with one coordinate per name and a constant SPD mass block; returns its index.")
      .def("add_planar_body", [](PyBuilder& b, const std::vector<std::string>& names, double mass, double inertia) {
            if (names.size() != 3)
              throw py::value_error("add_planar_body: expected 3 coordinate names (x, y, theta), got " +
                                    std::to_string(names.size()));
            return b.builder.add_planar_body({names[0], names[1], names[2]}, mass, inertia);
          }, py::arg("names"), py::arg("mass"), py::arg("inertia"),
          "A planar rigid body (x, y, theta of its centre of mass), M = diag(m, m, I); returns its index.")
      .def("add_rigid_body", [](PyBuilder& b, double mass, const py::object& inertia, int translation,
                                std::string name, bool any_inertia) {
            RigidBody body;
            body.mass = mass;
            body.inertia = inertia_of(inertia);
            body.translation = translation;
            body.name = std::move(name);
            body.any_inertia = any_inertia;
            return b.builder.add_rigid_body(body);
          }, py::arg("mass") = 1.0, py::arg("inertia") = 1.0,
          py::arg("translation") = 0, py::arg("name") = "", py::arg("any_inertia") = false,
          R"(A 3-D rigid body (core/include/nonholo/rigid_body.hpp); returns its index. Its configuration
is a unit quaternion (w, x, y, z) and the position of its centre in R^d, d = translation: 0 (a
fixed point), 2 (the centre moves in a horizontal plane) or 3 (free); its velocities are the
body-frame angular velocity Omega, then the centre's velocity. inertia: the central inertia in
the body frame, a 3x3 SPD matrix, its 3 principal moments or one number J (J Id). Coordinates
are named qw<name>, qx<name>, ..., x<name>; velocities wx<name>, ..., vx<name> (name: the
body's index when empty). Principal moments that break the triangle inequality (one above the
sum of the other two: no rigid body has them) are refused unless any_inertia=True.)")
      .def("reserve", [](PyBuilder& b, int bodies, int coordinates, int rows, int values) {
            b.builder.reserve(bodies, coordinates, rows, values);
          }, py::arg("bodies"), py::arg("coordinates"), py::arg("rows"), py::arg("values"),
          R"(Optional: room for a model of this size (bodies, coordinates, rows of mu and their nonzero
values), so that a million bodies are added without regrowing the builder's arrays.)");
}

// Rows, bias, gaps, potential, forces and momentum maps as callbacks (Python callables).
void builder_callbacks(py::class_<PyBuilder>& c) {
  c.def("add_one_form", [](PyBuilder& b, const std::vector<int>& columns, std::string label) {
            return b.builder.add_one_form(columns, std::move(label));
          }, py::arg("columns"), py::arg("label") = "",
          "A constraint row mu_a(q) qdot = 0 on these columns (its fixed pattern); returns the row index.")
      .def("add_holonomic_row", [](PyBuilder& b, const std::vector<int>& columns, std::string label) {
            return b.builder.add_holonomic_row(columns, std::move(label));
          }, py::arg("columns"), py::arg("label") = "",
          "A row that is the gradient of a holonomic constraint g_j(q) = 0 (give its g with gap()).")
      .def("one_form_values", [](PyBuilder& b, py::object f) {
            b.builder.one_form_values(one_form_values_callback(callable(b, std::move(f))));
          }, py::arg("values"),
          "values(q) -> the rows' entries, row by row in the order of each row's columns (nnz values).")
      .def("one_form_bias", [](PyBuilder& b, py::object f) {
            b.builder.one_form_bias(one_form_bias_callback(callable(b, std::move(f))));
          }, py::arg("bias"), "bias(q, qdot) -> (d/dt mu(q)) qdot, one value per row (optional).")
      .def("gap", [](PyBuilder& b, py::object f) { b.builder.gap(gap_callback(callable(b, std::move(f)))); },
          py::arg("gap"), "gap(q) -> g(q), one value per holonomic row in declaration order.")
      .def("potential", [](PyBuilder& b, py::object value, py::object gradient) {
            b.builder.potential(potential_callback(callable(b, std::move(value))),
                                gradient_callback(callable(b, std::move(gradient))));
          }, py::arg("value"), py::arg("gradient"), "value(q) -> V (a float), gradient(q) -> dV/dq (n values).")
      .def("external_force", [](PyBuilder& b, py::object f) {
            b.builder.external_force(force_callback(callable(b, std::move(f))));
          }, py::arg("force"), "force(t, q) -> F(t, q), n values.")
      .def("momentum_map", [](PyBuilder& b, const std::string& name, py::object f) {
            b.builder.momentum_map(name, momentum_map_callback(name, callable(b, std::move(f))));
          }, py::arg("name"), py::arg("map"), "map(q, p) -> J (a float), linear in p.");
}

// The local elements (nonholo/elements.hpp): no Python callable at step time unless given one.
void builder_elements(py::class_<PyBuilder>& c) {
  c.def("add_knife_edge", [](PyBuilder& b, int body, double a, std::string label) {
            return b.builder.add_knife_edge({body, a}, std::move(label));
          }, py::arg("body"), py::arg("a") = 0.0, py::arg("label") = "",
          "A blade at C - a e(theta) of a planar body (one row); returns the row index.")
      .def("add_hitch", [](PyBuilder& b, int rear, int front, double d, double f, std::string label) {
            return b.builder.add_hitch({rear, front, d, f}, std::move(label));
          }, py::arg("rear"), py::arg("front"), py::arg("d"), py::arg("f"), py::arg("label") = "",
          "Holds C_r - d e(theta_r) on C_f + f e(theta_f) (two holonomic rows); returns the first row's index.")
      .def("add_torsional_spring", [](PyBuilder& b, int first, int second, double k, double rest) {
            b.builder.add_torsional_spring({first, second, k, rest});
          }, py::arg("first"), py::arg("second"), py::arg("k"), py::arg("rest") = 0.0,
          "V = (k/2)(theta_first - theta_second - rest)^2.")
      .def("add_thrust", [](PyBuilder& b, int body, const py::object& force, const py::object& torque) {
            Thrust t{body, time_function(b, force, "force"), time_function(b, torque, "torque")};
            b.builder.add_thrust(std::move(t));
          }, py::arg("body"), py::arg("force") = py::none(), py::arg("torque") = py::none(),
          "force(t) along the body's heading and torque(t) on its angle: each None, a number or a callable of t.")
      .def("add_body_axis_constraint", [](PyBuilder& b, int body, const py::object& axis, std::string label) {
            return b.builder.add_body_axis_constraint({body, vector3(axis, "add_body_axis_constraint: axis")},
                                                      std::move(label));
          }, py::arg("body"), py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("label") = "",
          "<Omega, a> = 0 with a fixed in the body (the Suslov problem): one row; returns its index.")
      .def("add_space_axis_constraint", [](PyBuilder& b, int body, const py::object& axis, std::string label) {
            return b.builder.add_space_axis_constraint({body, vector3(axis, "add_space_axis_constraint: axis")},
                                                       std::move(label));
          }, py::arg("body"), py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("label") = "",
          "<Omega, R^T e> = 0 with e fixed in space (the Veselova problem): one row; returns its index.")
      .def("add_rolling_ball", [](PyBuilder& b, int body, double radius, std::string label) {
            return b.builder.add_rolling_ball({body, radius}, std::move(label));
          }, py::arg("body"), py::arg("radius") = 1.0, py::arg("label") = "",
          R"(A ball (centre of mass at its centre: the Chaplygin ball) rolling without slipping on z = 0:
two rows, and a holonomic height row with translation 3; returns the first row's index.)")
      .def("add_rolling_disk", [](PyBuilder& b, int body, double radius, std::string label) {
            return b.builder.add_rolling_disk({body, radius}, std::move(label));
          }, py::arg("body"), py::arg("radius") = 1.0, py::arg("label") = "",
          R"(A thin disk (its axis the body's e3) rolling without slipping on z = 0: three rows, the
vertical one holonomic; the body needs translation 3. Returns the first row's index.)")
      .def("add_rod", [](PyBuilder& b, int first, int second, double length, std::string label) {
            return b.builder.add_rod({first, second, length}, std::move(label));
          }, py::arg("first"), py::arg("second"), py::arg("length"), py::arg("label") = "",
          "A massless rod of this length between two bodies' centres (one holonomic row); returns its index.")
      .def("add_gravity", [](PyBuilder& b, double g) { b.builder.add_gravity(g); }, py::arg("g") = 9.81,
          "Gravity g along -e3 on every rigid body with translation 3 (an external force -m g e3).")
      .def("add_body_torque", [](PyBuilder& b, int body, const py::object& torque) {
            unless_refused(b, [&] {
              b.builder.add_body_torque(
                  {body, time_vector(b, torque, "body_torque", "body torque", body, "the torque in the body frame")});
            });
          }, py::arg("body"), py::arg("torque"),
          "torque(t) -> 3 numbers, the torque on a rigid body in its body frame (or 3 numbers: constant).")
      .def("add_body_force", [](PyBuilder& b, int body, const py::object& force) {
            unless_refused(b, [&] {
              b.builder.add_body_force(
                  {body, time_vector(b, force, "body_force", "body force", body, "the force on the centre, in space")});
            });
          }, py::arg("body"), py::arg("force"),
          R"(force(t) -> 3 numbers, the force on a rigid body's centre in space (or 3 numbers: constant);
a body moving in a plane ignores the vertical component.)");
}

}  // namespace

void bind_builder(py::module_& m) {
  py::class_<PyBuilder> c(m, "ModelBuilder", R"(Builds a Model, validating everything it is given (ValueError names the body,
row or column at fault). Callbacks are Python callables given copies of q (and qdot, p) as
1-D float64 arrays; those filling a vector return a 1-D array (or sequence) of its length.
Rows from add_one_form cannot be mixed with element rows (add_knife_edge, add_hitch, the
rigid-body constraints). With 3-D rigid bodies (add_rigid_body) q has n_q entries and every
vector in velocity space (rows' columns, gradients, forces, generators) n_v (Model.num_velocities).)");
  builder_bodies(c);
  builder_callbacks(c);
  builder_elements(c);
  c.def("symmetry", [](PyBuilder& b, const std::string& name, py::object generator, py::object body,
                       py::object value) {
            if (!body.is_none() && !py::isinstance<py::int_>(body))
              throw py::type_error("symmetry '" + name + "': body must be an int (a body's index), got " +
                                   callback_detail::type_name(body));
            const int index = body.is_none() ? -1 : body.cast<int>();
            SymmetryGenerator xi;
            if (index >= 0) {
              const ModelBuilder::VelocityRange range = b.builder.velocities_of(index);
              xi = local_generator_callback(name, callable(b, std::move(generator)), index, range.first, range.count);
            } else {
              xi = generator_callback(name, callable(b, std::move(generator)));
            }
            MomentumMap j = value.is_none() ? MomentumMap{} : momentum_map_callback(name, callable(b, std::move(value)));
            b.builder.symmetry(name, std::move(xi), std::move(j), index);
          }, py::arg("name"), py::arg("generator"), py::kw_only(), py::arg("body") = py::none(),
          py::arg("value") = py::none(),
          R"(A horizontal symmetry by its generator xi(q) -> n_v values (velocity entries: a rigid body's
Omega in its body frame, then its centre's velocity), lying in the constraint distribution. Its
momentum map J = <xi(q), p> is added under `name`, and the restarts keep it exactly.

body: the symmetry is local to that body (xi is zero outside its velocities): the generator
returns the body's entries only (Model.velocity_names says which), or all n_v with zeros
elsewhere; the restarts then store its direction in O(1), so a chain of N balls keeps N spins in
O(N) memory. value: J(q, p) itself, computed directly (it must equal <xi(q), p>: checked at the
start), cheaper than through xi for a local symmetry of a large model.)")
      .def_property_readonly("calls_python", [](const PyBuilder& b) { return b.calls_python; },
                             "True once a Python callable has been given to it; the models it builds then call Python.")
      .def("build", [](const PyBuilder& b) { return PyModel{b.builder.build(), b.calls_python}; },
          "The immutable Model (the builder can go on being used).");
}

namespace {

// The model's sizes, names and what it has, read-only.
void model_properties(py::class_<PyModel>& c) {
  c.def_property_readonly("num_coordinates", [](const PyModel& p) { return p.model.num_coordinates(); },
                             "The velocity count n_v (its older name: every body was planar then, n_q = n_v).")
      .def_property_readonly("num_configuration", [](const PyModel& p) { return p.model.num_configuration(); },
                             "n_q, the size of q (n_v plus one per 3-D rigid body: a quaternion against Omega).")
      .def_property_readonly("num_velocities", [](const PyModel& p) { return p.model.num_velocities(); },
                             "n_v, the size of p, of forces, of a row of mu and of a symmetry's generator.")
      .def_property_readonly("num_bodies", [](const PyModel& p) { return p.model.num_bodies(); },
                             "The number of bodies, in the order added.")
      .def_property_readonly("num_one_forms", [](const PyModel& p) { return p.model.num_one_forms(); },
                             "m, the rows of mu (one-forms and holonomic rows): the size of State.lam.")
      .def_property_readonly("num_one_form_values", [](const PyModel& p) { return p.model.num_one_form_values(); },
                             "nnz(mu): the number of values one_form_values() returns.")
      .def_property_readonly("num_holonomic", [](const PyModel& p) { return p.model.num_holonomic(); },
                             "The number of holonomic constraints g(q) = 0 (hitches, rods, ...): one per holonomic "
                             "row.")
      .def_property_readonly("coordinate_names", [](const PyModel& p) { return p.model.coordinate_names(); },
                             "The names of the n_q entries of q.")
      .def_property_readonly("velocity_names", [](const PyModel& p) { return p.model.velocity_names(); },
                             "The names of the n_v velocity entries (coordinate_names unless there are rigid bodies).")
      .def_property_readonly("has_rigid_bodies", [](const PyModel& p) { return p.model.has_rigid_bodies(); },
                             "Whether the model has 3-D rigid bodies (ModelBuilder.add_rigid_body; then "
                             "n_q > n_v).")
      .def_property_readonly("holonomic_rows", [](const PyModel& p) { return p.model.holonomic_rows(); },
                             "The rows of mu that are gradients of holonomic constraints g(q) = 0, in "
                             "declaration order.")
      .def_property_readonly("momentum_map_names", [](const PyModel& p) {
        std::vector<std::string> names;
        for (const NamedMomentumMap& j : p.model.momentum_maps()) names.push_back(j.name);
        return names;
      }, "The names of the momentum maps and symmetries, in declaration order (that of momentum_maps()).")
      .def_property_readonly("has_analytic_bias", [](const PyModel& p) { return p.model.has_analytic_bias(); },
                             "Whether the model gives its bias (d/dt mu) qdot in closed form "
                             "(ModelBuilder.one_form_bias).")
      .def_property_readonly("has_potential", [](const PyModel& p) { return p.model.has_potential(); },
                             "Whether a potential V(q) is given.")
      .def_property_readonly("has_external_force", [](const PyModel& p) { return p.model.has_external_force(); },
                             "Whether an external force F(t, q) is given.")
      .def_property_readonly("has_elements", [](const PyModel& p) { return p.model.has_elements(); },
                             "Whether the model is built from constraint elements (add_knife_edge, add_hitch, the "
                             "rigid-body constraints, ...): its one-form values, bias, gaps, potential and forces "
                             "are then the elements' own.")
      .def_property_readonly("is_chain", [](const PyModel& p) { return p.model.is_chain(); },
                             "Whether the explicit step can stream the model body by body (a chain of elements): "
                             "backend 'auto' then chooses 'banded'.")
      .def_property_readonly("performance_note", [](const PyModel& p) { return p.model.performance_note(); },
                             "What in the model's structure makes its steps slower than they could be ('' when "
                             "nothing): a chain of knife edges and hitches built in an order the fused chain step "
                             "does not read (it says which row and how to order them), or a body touched by so many "
                             "rows that C has a dense block (its cost per step).")
      .def_property_readonly("calls_python", [](const PyModel& p) { return p.calls_python; },
                             "True when a callback is Python; when false, step() and steps() release the GIL.");
}

}  // namespace

void bind_model(py::module_& m) {
  py::class_<PyModel> c(m, "Model", "An immutable model (ModelBuilder.build()).");
  model_properties(c);
  c.def("body", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies()) throw py::index_error("body " + std::to_string(b) + " out of range");
            return py::make_tuple(p.model.body(b).offset, p.model.body(b).size);
          }, py::arg("b"), R"((first entry, number of entries) of body b in the velocities (p, forces, columns of mu);
the same as in q unless a 3-D rigid body comes first or it is one (body_configuration).)")
      .def("body_configuration", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies())
              throw py::index_error("body " + std::to_string(b) + " out of range");
            return py::make_tuple(p.model.body(b).q_offset, p.model.body(b).q_size);
          }, py::arg("b"), "(first entry, number of entries) of body b in the configuration q.")
      .def("mass_block", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies()) throw py::index_error("body " + std::to_string(b) + " out of range");
            const Body& body = p.model.body(b);
            Eigen::MatrixXd block(body.size, body.size);
            for (int i = 0; i < body.size; ++i)
              for (int j = 0; j < body.size; ++j) block(i, j) = p.model.mass().entry(body.offset + i, body.offset + j);
            return block;
          }, py::arg("b"), R"(Body b's constant mass block: its square block of M over the body's velocity entries
(model.body(b)); for a 3-D rigid body the inertia in the body frame, then m on the centre's velocity.)")
      .def("one_form_columns", [](const PyModel& p) {
            const sparse::RowPattern& pattern = p.model.one_form_pattern();
            std::vector<std::vector<int>> rows(static_cast<std::size_t>(pattern.rows));
            for (int r = 0; r < pattern.rows; ++r)
              rows[static_cast<std::size_t>(r)].assign(pattern.col_idx.begin() + pattern.row_ptr[r],
                                                       pattern.col_idx.begin() + pattern.row_ptr[r + 1]);
            return rows;
          }, "The columns of each one-form row (the pattern of one_form_values).")
      .def("one_form_values", [](const PyModel& p, const Vector& q) {
            if (q.size() != p.model.num_configuration())
              throw py::value_error("one_form_values: expected " + std::to_string(p.model.num_configuration()) +
                                    " coordinates, got " + std::to_string(q.size()));
            Vector mu = Vector::Zero(p.model.num_one_form_values());
            if (mu.size() > 0) p.model.one_form_values(q, mu);
            return mu;
          }, py::arg("q"), "mu(q)'s entries in pattern order.")
      .def("__repr__", [](const PyModel& p) {
        std::ostringstream os;
        os << "<nonholo.Model: " << p.model.num_bodies() << " bodies, " << p.model.num_configuration()
           << " coordinates, ";
        if (p.model.num_velocities() != p.model.num_configuration()) os << p.model.num_velocities() << " velocities, ";
        os << p.model.num_one_forms() << " one-forms>";
        return os.str();
      });
}

// The quaternion helpers of nonholo/rigid_body.hpp.
void bind_quaternions(py::module_& m) {
  m.def("axis_angle_quaternion",
        [](const py::object& axis, double angle) {
          const Eigen::Vector4d q = axis_angle_quaternion(vector3(axis, "axis_angle_quaternion: axis"), angle);
          return py::array_t<double>(4, q.data());
        },
        py::arg("axis"), py::arg("angle"),
        "The unit quaternion (w, x, y, z) of the rotation by angle about axis (normalised; nonzero and finite).");
  m.def("quaternion_matrix",
        [](const py::object& q) {
          auto a = Array::ensure(q);
          if (!a) {
            PyErr_Clear();
            throw py::value_error("quaternion_matrix: expected 4 numbers (w, x, y, z), got " +
                                  callback_detail::type_name(q));
          }
          if (a.ndim() != 1 || a.size() != 4)
            throw py::value_error("quaternion_matrix: expected 4 numbers (w, x, y, z), got an array of " +
                                  std::to_string(a.size()) + " in " + std::to_string(a.ndim()) + " dimension(s)");
          const Eigen::Vector4d v(a.data()[0], a.data()[1], a.data()[2], a.data()[3]);
          if (!v.allFinite() || !(v.norm() > 0.0)) {
            std::ostringstream os;
            os << "quaternion_matrix: q = (" << num(v[0]) << ", " << num(v[1]) << ", " << num(v[2]) << ", " << num(v[3])
               << ") must be finite and nonzero";
            throw py::value_error(os.str());
          }
          return Eigen::Matrix3d(quaternion_matrix(v));
        },
        py::arg("q"),
        "The rotation matrix R of the quaternion q / ``|q|`` (w, x, y, z): R x = q x q^*, columns the body axes in space.");
}

}  // namespace nonholo::python
