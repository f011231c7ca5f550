# nonholo_eigen_alignment(OUT): EIGEN_MAX_STATIC_ALIGN_BYTES as the library's sources see it
# (with -march=${NONHOLO_ARCH} when set), found by compiling a static_assert for each candidate.
include(CheckCXXSourceCompiles)
function(nonholo_eigen_alignment out)
  get_target_property(eigen_includes Eigen3::Eigen INTERFACE_INCLUDE_DIRECTORIES)
  set(CMAKE_REQUIRED_INCLUDES ${eigen_includes})
  set(CMAKE_REQUIRED_QUIET ON)
  if(NONHOLO_ARCH)
    set(CMAKE_REQUIRED_FLAGS "-march=${NONHOLO_ARCH}")
  endif()
  foreach(bytes 16 32 64 0 8 128)
    string(MAKE_C_IDENTIFIER "nonholo_eigen_align_${bytes}_${NONHOLO_ARCH}" found)
    check_cxx_source_compiles("#include <Eigen/Core>
static_assert(EIGEN_MAX_STATIC_ALIGN_BYTES == ${bytes}, \"\");
int main() { return 0; }" ${found})
    if(${found})
      set(${out} ${bytes} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  message(FATAL_ERROR "nonholo: cannot tell EIGEN_MAX_STATIC_ALIGN_BYTES with the flags '${CMAKE_REQUIRED_FLAGS}'")
endfunction()
