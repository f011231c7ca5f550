# FindCHOLMOD: CHOLMOD from SuiteSparse installations that ship no CMake package
# (Debian bookworm's SuiteSparse 5.12). Defines the imported target SuiteSparse::CHOLMOD,
# the name SuiteSparse >= 7 uses in its own config package.
#
#   CHOLMOD_FOUND, CHOLMOD_INCLUDE_DIR, CHOLMOD_LIBRARY, CHOLMOD_VERSION
#   Hints: CHOLMOD_ROOT or SuiteSparse_ROOT.

find_path(CHOLMOD_INCLUDE_DIR cholmod.h
  HINTS ${CHOLMOD_ROOT} ${SuiteSparse_ROOT} ENV CHOLMOD_ROOT ENV SuiteSparse_ROOT
  PATH_SUFFIXES include include/suitesparse suitesparse)
find_library(CHOLMOD_LIBRARY NAMES cholmod
  HINTS ${CHOLMOD_ROOT} ${SuiteSparse_ROOT} ENV CHOLMOD_ROOT ENV SuiteSparse_ROOT
  PATH_SUFFIXES lib lib64)
find_library(SUITESPARSE_CONFIG_LIBRARY NAMES suitesparseconfig
  HINTS ${CHOLMOD_ROOT} ${SuiteSparse_ROOT} ENV CHOLMOD_ROOT ENV SuiteSparse_ROOT
  PATH_SUFFIXES lib lib64)

if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h" _cholmod_main REGEX "^#define CHOLMOD_MAIN_VERSION[ \t]+[0-9]+")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h" _cholmod_sub REGEX "^#define CHOLMOD_SUB_VERSION[ \t]+[0-9]+")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h" _cholmod_patch REGEX "^#define CHOLMOD_SUBSUB_VERSION[ \t]+[0-9]+")
  string(REGEX REPLACE ".*VERSION[ \t]+([0-9]+).*" "\\1" _cholmod_main "${_cholmod_main}")
  string(REGEX REPLACE ".*VERSION[ \t]+([0-9]+).*" "\\1" _cholmod_sub "${_cholmod_sub}")
  string(REGEX REPLACE ".*VERSION[ \t]+([0-9]+).*" "\\1" _cholmod_patch "${_cholmod_patch}")
  set(CHOLMOD_VERSION "${_cholmod_main}.${_cholmod_sub}.${_cholmod_patch}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR
  VERSION_VAR CHOLMOD_VERSION)

if(CHOLMOD_FOUND AND NOT TARGET SuiteSparse::CHOLMOD)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}")
  if(SUITESPARSE_CONFIG_LIBRARY)
    set_property(TARGET SuiteSparse::CHOLMOD APPEND PROPERTY
      INTERFACE_LINK_LIBRARIES "${SUITESPARSE_CONFIG_LIBRARY}")
  endif()
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY SUITESPARSE_CONFIG_LIBRARY)
