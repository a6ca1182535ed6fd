# Run after a test executable is linked (transient_gtest_suites, tests/CMakeLists.txt): lists its
# GoogleTest tests with --gtest_list_tests and writes one ctest test per suite (or, with
# each_test, per test) into tests_file.
#   usage: cmake -D CONFIG=<file written by transient_gtest_suites> -P discover_gtest_suites.cmake
# CONFIG sets executable, prefix, each_test, properties (set_tests_properties arguments,
# bracket-quoted), working_directory, timeout (seconds for the listing) and tests_file.
include("${CONFIG}")

execute_process(
  COMMAND "${executable}" --gtest_list_tests
  WORKING_DIRECTORY "${working_directory}"
  TIMEOUT ${timeout}
  RESULT_VARIABLE result
  OUTPUT_VARIABLE output
  ERROR_VARIABLE error)
if(NOT result EQUAL 0)
  file(REMOVE "${tests_file}")
  message(FATAL_ERROR "listing the tests of ${executable} failed (${result}):\n${output}\n${error}")
endif()

# The listing: a suite's name and a dot at the start of a line ("Suite.", "Instance/Suite.",
# "Instance/Suite/0."), its tests' names indented by two spaces below it; a parameterized one is
# followed by a comment ("  # GetParam() = ..."), dropped first, since it may hold any character.
# The line gtest_main prints first ("Running main() from ...") has spaces and matches neither.
string(REGEX REPLACE "  #[^\n]*" "" output "${output}")
string(REPLACE ";" "" output "${output}")
string(REGEX MATCHALL "[^\n]+" lines "${output}")
set(content "")
set(names "")
set(suite "")
foreach(line IN LISTS lines)
  if(line MATCHES "^([^ ]+)\\.$")
    set(suite "${CMAKE_MATCH_1}")
    if(NOT each_test)
      list(APPEND names "${suite}")
    endif()
  elseif(line MATCHES "^  ([^ ]+)$" AND each_test AND NOT suite STREQUAL "")
    list(APPEND names "${suite}.${CMAKE_MATCH_1}")
  endif()
endforeach()
foreach(name IN LISTS names)
  if(each_test)
    set(filter "${name}")
  else()
    set(filter "${name}.*")
  endif()
  string(APPEND content
    "add_test([==[${prefix}${name}]==] [==[${executable}]==] [==[--gtest_filter=${filter}]==])\n"
    "set_tests_properties([==[${prefix}${name}]==] PROPERTIES"
    " WORKING_DIRECTORY [==[${working_directory}]==]${properties})\n")
endforeach()
if(names STREQUAL "")
  file(REMOVE "${tests_file}")
  message(FATAL_ERROR "${executable} lists no tests:\n${output}")
endif()
file(WRITE "${tests_file}" "${content}")
