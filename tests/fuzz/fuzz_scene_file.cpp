// libFuzzer target: any bytes given to the scene-file parser either give a model, a
// consistent start and a few steps, or end in std::invalid_argument (the documented error).
// Anything else — another exception, a crash, a leak, undefined behaviour, a timeout — is a
// finding. Built and run by tools/fuzz.sh.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/start.hpp>
#include <nonholo/workspace.hpp>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace nonholo;
  try {
    const auto info = scenarios::parse_scene_text(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
    const scenarios::SceneSetup setup = info.build(info.defaults());
    Workspace ws(setup.model);
    State state = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
    RattleOptions options;
    options.h = info.default_dt;
    for (int k = 0; k < 3 && step(setup.model, ws, state, options) == Status::Ok; ++k) {
    }
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
