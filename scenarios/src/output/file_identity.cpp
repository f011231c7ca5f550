// Files compared as files (file_identity.hpp).
#include "output/file_identity.hpp"

#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace nonholo::scenarios {

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code e1, e2;
  if (fs::exists(a, e1) && fs::exists(b, e2)) {
    const bool same = fs::equivalent(a, b, e1);
    return !e1 && same;
  }
  const fs::path ca = fs::weakly_canonical(fs::absolute(a, e1), e1), cb = fs::weakly_canonical(fs::absolute(b, e2), e2);
  return !e1 && !e2 && ca == cb;
}

void refuse_shared_files(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  auto named = [](const NamedPath& p) { return !p.path.empty() && p.path != "-"; };
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const NamedPath& o = outputs[i];
    if (!named(o)) continue;
    for (std::size_t j = i + 1; j < outputs.size(); ++j)
      if (named(outputs[j]) && same_file(o.path, outputs[j].path))
        throw std::invalid_argument(o.option + " " + o.path + " and " + outputs[j].option + " " + outputs[j].path +
                                    " are the same file: one would overwrite the other; give each its own file");
    for (const NamedPath& in : inputs)
      if (named(in) && same_file(o.path, in.path))
        throw std::invalid_argument(o.option + " " + o.path + " is " + in.option + " " + in.path +
                                    " (the same file, through a link or another name): writing it would destroy "
                                    "the input; write elsewhere");
  }
}

}  // namespace nonholo::scenarios
