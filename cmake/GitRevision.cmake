# The checkout's git revision at configure time, for <nonholo/version.hpp> (kGitRevision): from
# git in a checkout; in a source distribution (python3 -m build makes the wheel from one, without
# .git) from the GIT_REVISION file setup.py's sdist writes into it; else "unknown" (a wheel built
# from the sdist said "unknown"). Also runnable as a script for its test:
#   cmake -DSOURCE=DIR -P cmake/GitRevision.cmake   prints "git revision: <rev>"
function(nonholo_git_revision source out)
  set(revision "")
  if(EXISTS ${source}/GIT_REVISION)  # only an sdist has it (first: unpacked inside another checkout,
    file(STRINGS ${source}/GIT_REVISION lines LIMIT_COUNT 1)  # git would name that one)
    if(lines MATCHES "^[0-9a-f]+$")
      set(revision ${lines})
    endif()
  endif()
  if(revision STREQUAL "")
    execute_process(COMMAND git rev-parse --short=12 HEAD WORKING_DIRECTORY ${source}
                    OUTPUT_VARIABLE revision OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0 OR revision STREQUAL "")
      set(revision "unknown")
    endif()
  endif()
  set(${out} ${revision} PARENT_SCOPE)
endfunction()

if(CMAKE_SCRIPT_MODE_FILE AND DEFINED SOURCE)
  nonholo_git_revision(${SOURCE} revision)
  message("git revision: ${revision}")
endif()
