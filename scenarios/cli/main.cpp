#include <nonholo/scenarios/command_line.hpp>

#include <iostream>

int main(int argc, char** argv) {
  return nonholo::scenarios::run_command_line(argc, argv, std::cout, std::cerr);
}
