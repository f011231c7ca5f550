// The reference integrator without SUNDIALS (CMake option NONHOLO_WITH_ARKODE off): RK4 only;
// the ARKODE methods are refused at the start with what is missing.
#include <nonholo/reference/integrators.hpp>

#include <stdexcept>
#include <string>

namespace nonholo::reference {

struct Integrator::Arkode {};

void Integrator::ArkodeDeleter::operator()(Arkode* arkode) const { delete arkode; }

void Integrator::start_arkode(double) {
  throw std::invalid_argument(std::string("method ") + to_string(method_) +
                              ": this nonholo was built without SUNDIALS ARKODE (CMake option NONHOLO_WITH_ARKODE; "
                              "Debian: libsundials-dev); the reflection method, DLA and rk4 are here");
}

Status Integrator::arkode_advance(double) { return Status::MethodNotApplicable; }

}  // namespace nonholo::reference
