# Warnings for the project's own targets only (not for dependencies' headers).
function(nonholo_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
      -Wno-sign-conversion)
    # GCC 12's AVX-512 intrinsics (Eigen's vector code under NONHOLO_ARCH=native on such a
    # machine) warn "'__Y' may be used uninitialized" inside the compiler's own header, about
    # 2000 times a build, and a masked load of a Vector3d "partly outside array bounds" (it is
    # masked); the portable build keeps both warnings.
    if(NONHOLO_ARCH AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
      target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized -Wno-array-bounds)
    endif()
  endif()
endfunction()
