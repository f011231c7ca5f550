#pragma once
// Outputs that would overwrite each other or an input: refused before anything is written
// (`batch --out b.h5 --states b.h5` lost its table; `--out` through a link to the scene file
// overwrote it). Paths are compared as files, not as text: links followed, hard links too.
#include <string>
#include <vector>

namespace nonholo::scenarios {

// Whether two paths name one file: when both exist, by device and inode (links followed);
// otherwise by their canonical forms (the links of the parts that exist followed).
bool same_file(const std::string& a, const std::string& b);

// An option and the path it names ("" or "-": none).
struct NamedPath {
  std::string option;  // "--out", "--states", "the scene file", ...
  std::string path;
};

// Throws std::invalid_argument naming both when two outputs are one file, or an output is an input.
void refuse_shared_files(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

}  // namespace nonholo::scenarios
