#pragma once
// A step never throws: the model's callbacks are user code and may (a std::function that
// throws, a Python callback that raises). guard_callbacks runs a step's body and turns an
// escaping exception into Status::CallbackFailed with the exception's text; the body leaves
// the state as it was (a step commits only at its end), so the caller may retry or stop.
// No cost when nothing is thrown (zero-cost exception tables).
#include <nonholo/status.hpp>

#include <exception>

namespace nonholo::detail {

template <class Ws, class Body>
Status guard_callbacks(Ws& ws, Body&& body) noexcept {
  try {
    return body();
  } catch (const std::exception& e) {
    return ws.fail(Status::CallbackFailed, "a model callback threw: %s", e.what());
  } catch (...) {
    return ws.fail(Status::CallbackFailed, "a model callback threw an exception that is not a std::exception");
  }
}

}  // namespace nonholo::detail
