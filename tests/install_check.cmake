# cmake -P script: install the current build to WORK_DIR/prefix, then configure, build and
# run one consumer of each component against it: examples/embed (core, with SUNDIALS hidden,
# plus the user guide's "Using the library" program extracted from docs/guide/library.md),
# examples/embed_reference
# and examples/embed_scenarios, and examples/embed_mpi WITH_MPI. CONSUMER_FLAGS: the build's
# compiler flags (sanitizers).
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)

# The guide's programs: the first two ```cpp blocks of docs/guide/library.md (a model run as the
# tool runs a scene, against the scenarios component; the step alone, against the core).
file(READ ${SOURCE_DIR}/docs/guide/library.md guide)
foreach(which run_program guide_program)
  if(NOT guide MATCHES "```cpp\n(.*)")
    message(FATAL_ERROR "docs/guide/library.md: no ```cpp block for ${which}")
  endif()
  string(FIND "${CMAKE_MATCH_1}" "```" end)
  string(SUBSTRING "${CMAKE_MATCH_1}" 0 ${end} program)
  file(WRITE ${WORK_DIR}/${which}.cpp "${program}")
  math(EXPR after "${end} + 3")
  string(SUBSTRING "${CMAKE_MATCH_1}" ${after} -1 guide)
endforeach()

# consumer(NAME EXAMPLE_DIR [CMAKE_ARGS...]): configure, build, run the executable NAME.
function(consumer name dir)
  set(build ${WORK_DIR}/${name})
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/${dir} -B ${build} -DCMAKE_BUILD_TYPE=Release
      -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}" ${ARGN})
  run(${CMAKE_COMMAND} --build ${build})
  run(${build}/${name})
endfunction()
# Core only: must configure although SUNDIALS cannot be found.
consumer(embed embed -DCMAKE_DISABLE_FIND_PACKAGE_SUNDIALS=ON
         -DNONHOLO_GUIDE_PROGRAM=${WORK_DIR}/guide_program.cpp)
run(${WORK_DIR}/embed/guide_program)
consumer(embed_reference embed_reference)
consumer(embed_scenarios embed_scenarios -DNONHOLO_RUN_PROGRAM=${WORK_DIR}/run_program.cpp)
execute_process(COMMAND ${WORK_DIR}/embed_scenarios/run_program WORKING_DIRECTORY ${WORK_DIR}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "scene=my_chain .* status=ok" OR NOT EXISTS ${WORK_DIR}/my_chain.h5)
  message(FATAL_ERROR "the guide's run program failed (${rc}): ${out}\n${err}")
endif()
if(WITH_MPI)  # one rank, without mpirun
  consumer(embed_mpi embed_mpi)
endif()
