# ddsnav_unit_tests(<target> LABEL <label> LIBRARIES <lib>... [SOURCES <extra>...] [DIR <dir>])
#
# One test layout: the unit tests of a library are <lib>/tests/test_*.cpp, all compiled into <target> and
# registered with ctest under LABEL. Every .cpp in the folder must follow that pattern, and the folder must
# hold at least one: a renamed or misnamed test file stops the configure step instead of silently leaving
# the suite (helpers such as *.hpp beside the tests are fine).
function(ddsnav_unit_tests target)
  cmake_parse_arguments(arg "" "LABEL;DIR;TIMEOUT" "LIBRARIES;SOURCES" ${ARGN})
  if(NOT arg_DIR)
    set(arg_DIR ${CMAKE_CURRENT_SOURCE_DIR}/tests)
  endif()
  if(NOT arg_LABEL)
    message(FATAL_ERROR "ddsnav_unit_tests(${target}): LABEL is required")
  endif()
  file(GLOB sources CONFIGURE_DEPENDS ${arg_DIR}/*.cpp)
  if(NOT sources)
    message(FATAL_ERROR "ddsnav_unit_tests(${target}): no test_*.cpp in ${arg_DIR}")
  endif()
  foreach(source ${sources})
    get_filename_component(name ${source} NAME)
    if(NOT name MATCHES "^test_[a-z0-9_]+\\.cpp$")
      message(FATAL_ERROR "ddsnav_unit_tests(${target}): ${source} does not follow the unit test naming "
                          "pattern test_<what>.cpp (lower case); rename it so the suite picks it up")
    endif()
  endforeach()
  add_executable(${target} ${sources} ${arg_SOURCES})
  target_link_libraries(${target} PRIVATE ${arg_LIBRARIES} GTest::gtest_main)
  target_compile_definitions(${target} PRIVATE DDSNAV_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set(properties LABELS ${arg_LABEL})
  if(arg_TIMEOUT)
    list(APPEND properties TIMEOUT ${arg_TIMEOUT})
  endif()
  gtest_discover_tests(${target} DISCOVERY_TIMEOUT 60 PROPERTIES ${properties})
endfunction()
