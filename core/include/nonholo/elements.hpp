#pragma once
// Local constraint elements (as Simbody and Chrono model constraints): each evaluates its own
// rows of mu (values, bias, gap) or its own force from its own bodies' coordinates. They act
// on planar bodies whose first three coordinates are (x, y, theta) of the centre of mass
// (ModelBuilder::add_planar_body). A model built from elements needs no one-form callback;
// when its rows run body by body (each element joins a body to the next one) the explicit
// step streams through it in one forward and one backward sweep (DESIGN.md section 7,
// core/src/chain_sweep.cpp). Add them with ModelBuilder::add_knife_edge and friends.
#include <functional>

namespace nonholo {

// A function of time (a thrust's force or torque).
using TimeFunction = std::function<double(double t)>;

// A blade at C - a e(theta), e = (cos, sin), rolling without side slip: one row
// [sin theta, -cos theta, a] on (x, y, theta).
struct KnifeEdge {
  int body = 0;
  double a = 0.0;
};

// The rear hitch point of `rear`, C_r - d e(theta_r), held on the front hitch point of
// `front`, C_f + f e(theta_f): g = C_r - d e_r - C_f - f e_f = 0 (two holonomic rows,
// x then y).
struct Hitch {
  int rear = 0, front = 0;
  double d = 0.0, f = 0.0;
};

// V = (k/2)(theta_first - theta_second - rest)^2.
struct TorsionalSpring {
  int first = 0, second = 0;
  double k = 0.0;
  double rest = 0.0;
};

// A force along the body's heading, force(t) e(theta), and a torque(t) on its angle; either
// may be empty.
struct Thrust {
  int body = 0;
  TimeFunction force, torque;
};

}  // namespace nonholo
