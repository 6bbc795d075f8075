# Install rules and the CMake package (find_package(ddsnav)): libraries with their headers, the stock
# executables, the message IDL, launch files and scenarios under share/ddsnav, and a Debian package.
# Kept in one place so the libraries' own CMakeLists only say what they build.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# Library target -> name in the package (ddsnav::<name>). Static helpers the exported ones link are
# exported too (CMake needs every target of the link closure in the export set).
set(ddsnav_exported
  ddsnav_msgs msgs  ddsnav_bus bus  ddsnav_runtime runtime  ddsnav_planner planner  ddsnav_mapper mapper
  ddsnav_tracker tracker  ddsnav_perception perception  ddsnav_sim sim  ddsnav_launch launch
  ddsnav_launch_bus launch_bus  ddsnav_mcap mcap  ddsnav_record record  ddsnav_nodes nodes
  ddsnav_test_harness testing)

set(ddsnav_library_targets "")
while(ddsnav_exported)
  list(POP_FRONT ddsnav_exported target name)
  list(APPEND ddsnav_library_targets ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  if(NOT TARGET ddsnav::${name})
    add_library(ddsnav::${name} ALIAS ${target})
  endif()
  # Build-tree include folders become $<BUILD_INTERFACE:...>, their headers are installed to include/.
  get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT dirs)
    set(dirs "")
  endif()
  set(wrapped "")
  foreach(dir ${dirs})
    if(dir MATCHES "^(${PROJECT_SOURCE_DIR}|${PROJECT_BINARY_DIR})/")
      list(APPEND wrapped "$<BUILD_INTERFACE:${dir}>")
      install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev
              FILES_MATCHING PATTERN "*.h" PATTERN "*.hpp" PATTERN "*.inc" PATTERN "tmp" EXCLUDE)
    else()
      list(APPEND wrapped "${dir}")
    endif()
  endforeach()
  list(APPEND wrapped "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${wrapped}")
endwhile()

install(TARGETS ${ddsnav_library_targets} EXPORT ddsnavTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
# The idlc headers of the stock types: a user IDL that includes a stock one compiles against them
# (ddsnav_add_messages), so they are installed apart from the C++ headers.
install(DIRECTORY ${PROJECT_BINARY_DIR}/idl/gen/cyclone/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ddsnav/cyclone
        FILES_MATCHING PATTERN "*.h")

# Every executable ddsnav ships (not the tests and fuzz replays).
set(ddsnav_programs ddsnav ddsnav-talker ddsnav-echo ddsnav-launch ddsnav-record ddsnav-play ddsnav-info
  ddsnav-bridge ddsnav-export ddsnav-plan ddsnav-bench ddsnav-bench-bus ddsnav-bench-record ddsnav-bench-bridge
  ddsnav-bench-mapper ddsnav-bench-perception ddsnav-bench-tracker
  ddsnav-sim ddsnav-perception ddsnav-mapper ddsnav-planner ddsnav-tracker ddsnav-monitor ddsnav-container
  ddsnav-security ddsnav-bench-roundtrip ddsnav-bench-intra ddsnav-bench-busy ddsnav-bench-mission ddsnav-test-with-domain)
if(NOT DDSNAV_BENCHMARKS)
  list(REMOVE_ITEM ddsnav_programs ${ddsnav_untested_benchmarks})
endif()
install(TARGETS ${ddsnav_programs} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

set(ddsnav_share ${CMAKE_INSTALL_DATADIR}/ddsnav)
file(GLOB ddsnav_idl_files ${PROJECT_SOURCE_DIR}/idl/*.idl)
install(FILES ${ddsnav_idl_files} DESTINATION ${ddsnav_share}/idl)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/configs/launch ${PROJECT_SOURCE_DIR}/configs/foxglove
        DESTINATION ${ddsnav_share})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/configs/scenarios DESTINATION ${ddsnav_share}
        FILES_MATCHING PATTERN "*.yaml")
install(FILES ${PROJECT_SOURCE_DIR}/cmake/DdsnavMessages.cmake ${PROJECT_SOURCE_DIR}/cmake/DdsnavUnitTests.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ddsnav)

install(EXPORT ddsnavTargets NAMESPACE ddsnav:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ddsnav)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/ddsnavConfig.cmake.in
  ${PROJECT_BINARY_DIR}/ddsnavConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ddsnav
  PATH_VARS CMAKE_INSTALL_BINDIR CMAKE_INSTALL_DATADIR CMAKE_INSTALL_INCLUDEDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ddsnavConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/ddsnavConfig.cmake ${PROJECT_BINARY_DIR}/ddsnavConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ddsnav)

# cpack -G DEB: a Debian 12 package; the dependencies are the runtime packages of what ddsnav links, and
# the -dev packages whose headers the installed headers include (a user builds against the package).
set(CPACK_PACKAGE_NAME ddsnav)
set(CPACK_PACKAGE_VENDOR "ddsnav")
set(CPACK_PACKAGE_CONTACT "ddsnav maintainers <ddsnav@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "DDS navigation stack: components, message SDK and test harness")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
# Shared-library dependencies of the binaries (Fast DDS, Cyclone, PCL, OMPL, ...) come from
# dpkg-shlibdeps; the list below adds what building against the package needs: the headers the
# installed headers include, the packages find_dependency() looks for, the two IDL compilers, and a C and
# C++ compiler with a build tool (a user project enables C for idlc's descriptors; g++ alone brings no
# `cc`, and cmake no `make`: scripts/test-deb found both missing on a fresh Debian 12).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS
  "cmake (>= 3.22), make | ninja-build, gcc, g++, libfastrtps-dev (>= 2.9), libfastcdr-dev, fastddsgen, cyclonedds-dev (>= 0.10), \
cyclonedds-tools (>= 0.10), libyaml-cpp-dev, libspdlog-dev, nlohmann-json3-dev, libeigen3-dev, liboctomap-dev, \
libnanoflann-dev, libcli11-dev, libzstd-dev, zlib1g-dev, libgtest-dev")
include(CPack)
