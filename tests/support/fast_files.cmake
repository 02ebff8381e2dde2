# SPDX-License-Identifier: Apache-2.0
# Included by ctest whenever it reads the tests (tests/CMakeLists.txt sets
# FAST_*): one entry, "fast: FILE", per test file with cases of the fast tier,
# which runs those cases in one relief_tests process. The files are what
# relief_tests lists itself (Catch's -#, a tag [#FILE] per source file), so
# a new file or case needs no change here.
#
# A fast case must not skip: the skip marker would have ctest report the
# whole file as skipped, whatever its other cases did (SKIP_REGULAR_EXPRESSION
# overrides the exit code). Cases that can skip (shared data, root) are in the
# slow tier, one entry each; here the marker fails the entry.
if(NOT EXISTS "${FAST_EXECUTABLE}")
  add_test(fast_NOT_BUILT fast_NOT_BUILT)
  return()
endif()
# (Catch 2 exits with the number of tags listed: the output is what counts.)
execute_process(COMMAND ${FAST_EXECUTOR} "${FAST_EXECUTABLE}" --filenames-as-tags --list-tags "${FAST_FILTER}"
                WORKING_DIRECTORY "${FAST_WORKING_DIRECTORY}"
                OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
string(REGEX MATCHALL "\\[#[A-Za-z0-9_]+\\]" _tags "${_out}")
if(NOT _tags)
  # An entry that fails and says why, rather than a fast tier of nothing.
  add_test(fast_files_not_listed "${CMAKE_COMMAND}" -E echo
           "relief_tests --filenames-as-tags --list-tags listed no files: ${_out} ${_err}")
  set_tests_properties(fast_files_not_listed PROPERTIES LABELS fast FAIL_REGULAR_EXPRESSION ".")
  return()
endif()
foreach(_tag IN LISTS _tags)
  string(REGEX REPLACE "^\\[#(.*)\\]$" "\\1" _file "${_tag}")
  add_test("fast: ${_file}" ${FAST_EXECUTOR} "${FAST_EXECUTABLE}" --filenames-as-tags "${_tag}${FAST_FILTER}" -w NoTests)
  set(_labels fast)
  list(FIND FAST_FRONT_END_FILES "${_file}" _front_end)  # (ctest has no policies: no IN_LIST)
  if(_front_end GREATER -1)
    list(APPEND _labels front-end)
  endif()
  list(FIND FAST_SCHEDULE_FILES "${_file}" _schedule)
  if(_schedule GREATER -1)
    list(APPEND _labels schedule)
  endif()
  set_tests_properties("fast: ${_file}" PROPERTIES
    WORKING_DIRECTORY "${FAST_WORKING_DIRECTORY}"
    FAIL_REGULAR_EXPRESSION "relief-test-skipped:"
    LABELS "${_labels}")
endforeach()
