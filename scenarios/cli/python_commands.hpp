#pragma once
// `nonholo animate` and `nonholo view` are written in Python (matplotlib and Pillow, an HTML
// writer): the executable hands them to `python3 -m nonholo._animation` / `nonholo._viewer`
// with the package it was built with, so that they are one tool with `run` and `batch`.

namespace nonholo::scenarios {

// Whether argv names one of those commands; then runs it and sets *exit_code to its exit code.
bool run_python_command(int argc, const char* const* argv, int* exit_code);

}  // namespace nonholo::scenarios
