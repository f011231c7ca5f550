#!/usr/bin/env bash
# The API reference: the C++ headers through Doxygen (docs/api/Doxyfile) into
# $NONHOLO_BUILD/docs/api/html, and the Python package as built through Sphinx (docs/api/conf.py)
# into $NONHOLO_BUILD/docs/python. Exits non-zero when either prints a warning (an undocumented
# public name, a malformed comment or docstring); both run, so one run shows every warning.
# Builds the Python module first (and with it the generated <nonholo/version.hpp>).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_require doxygen python3-sphinx
nonholo_build nonholo_python
NONHOLO_BUILD="$(cd "$NONHOLO_BUILD" && pwd)"  # absolute: Doxygen and Sphinx run elsewhere

version_header="$NONHOLO_BUILD/generated/nonholo/version.hpp"
version="$(sed -n 's/.*kVersion = "\([^"]*\)".*/\1/p' "$version_header")"
revision="$(sed -n 's/.*kGitRevision = "\([^"]*\)".*/\1/p' "$version_header")"
out="$NONHOLO_BUILD/docs"
rm -rf "$out/api" "$out/python" "$out/.doctrees"
mkdir -p "$out/api"

status=0
echo "nonholo: C++ API (Doxygen $(doxygen --version))" >&2
NONHOLO_ROOT="$NONHOLO_ROOT" NONHOLO_BUILD="$NONHOLO_BUILD" NONHOLO_VERSION="$version ($revision)" \
  doxygen "$NONHOLO_ROOT/docs/api/Doxyfile" || status=1
echo "nonholo: Python API (Sphinx)" >&2
# -E: read every docstring again (an incremental build would not repeat a warning); -W: any
# warning fails, --keep-going: after all of them are printed.
NONHOLO_BUILD="$NONHOLO_BUILD" /usr/bin/python3 -m sphinx -E -W --keep-going -q -b html \
  -d "$out/.doctrees" "$NONHOLO_ROOT/docs/api" "$out/python" || status=1

if ((status)); then
  echo "nonholo: the documentation build printed warnings (above): fix them" >&2
  exit 1
fi
echo "C++ API:    $out/api/html/index.html" >&2
echo "Python API: $out/python/index.html" >&2
