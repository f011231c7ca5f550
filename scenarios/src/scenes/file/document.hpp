#pragma once
// A scene file's text as a JSON document (document.cpp): read within the size limit, nesting
// checked before parsing, a key given twice refused, errors at their line and column.
#include <string>

#include "scenes/file/reader.hpp"

namespace nonholo::scenarios::scene_file {

// The whole file, after checking that it is a regular file within kMaxSceneFileBytes (a
// directory, /dev/zero or a pipe would otherwise fail oddly or be read for ever).
std::string read_file(const std::string& path);
// The document of the text; throws std::invalid_argument (path: line L, column C: what).
json parse_document(const std::string& text, const std::string& path);

}  // namespace nonholo::scenarios::scene_file
