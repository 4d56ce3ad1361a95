# Project-wide build rules: warnings as errors on project code only (third-party
# headers come in through imported targets, which CMake treats as SYSTEM).
add_library(mesocap_warnings INTERFACE)
target_compile_options(mesocap_warnings INTERFACE -Wall -Wextra -Werror
  # GCC 12 reports -Wrestrict false positives inside libstdc++'s std::string
  # operator+ at -O2/-O3 (GCC bug 105329); they are not in project code.
  $<$<AND:$<CXX_COMPILER_ID:GNU>,$<VERSION_LESS:$<CXX_COMPILER_VERSION>,13>>:-Wno-restrict>)

# Third-party and standard headers that nearly every translation unit parses,
# directly or through core/'s headers (3-5 s a file). With
# MESOCAP_PRECOMPILE_HEADERS each library and the test binaries precompile
# them once. It is off by default: in a file that uses a precompiled header,
# GCC 12 at -O2 and above reports its false positives inside libstdc++
# (-Wstringop-overflow, -Warray-bounds) that the system-header rule hides
# otherwise. The sanitize preset (-O1, the longest build) turns it on.
set(MESOCAP_PRECOMPILED_HEADERS <Eigen/Core> <Eigen/Geometry> <nlohmann/json.hpp>
  <filesystem> <functional> <map> <memory> <optional> <string> <vector>)

# Every library, test binary and program compiles as unity batches: each
# file parses the same Eigen, nlohmann, spdlog and OpenCV headers and
# instantiates the same templates, which at -O3 is most of its time (the
# acquisition library's nine files: 63 s of CPU one by one, 25 s as one
# batch). A source file's file-local names (anonymous namespaces) must
# therefore be distinct within its target. MESOCAP_UNITY_BATCH_SIZE=1
# compiles file by file.
set(MESOCAP_UNITY_BATCH_SIZE 16 CACHE STRING "Source files per unity batch (1: no unity build)")
# A unity batch includes the .cc files, so GCC judges them as headers: a
# class defined in one that holds a file-local type is then reported
# (-Wsubobject-linkage), though no other file can see the class.
if(MESOCAP_UNITY_BATCH_SIZE GREATER 1 AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(mesocap_warnings INTERFACE -Wno-subobject-linkage)
endif()
function(mesocap_unity_build target)
  if(MESOCAP_UNITY_BATCH_SIZE GREATER 1)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${MESOCAP_UNITY_BATCH_SIZE})
  endif()
endfunction()

# mesocap_library(NAME SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...)
# Defines the target mesocap::NAME. Headers live beside their sources and are
# included from the repository root ("core/image.h"). A library without
# sources yet is an INTERFACE target that carries its dependencies.
function(mesocap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  if(ARG_SOURCES)
    add_library(mesocap_${name} ${ARG_SOURCES})
    mesocap_unity_build(mesocap_${name})
    target_include_directories(mesocap_${name} PUBLIC ${PROJECT_SOURCE_DIR})
    target_link_libraries(mesocap_${name}
      PUBLIC ${ARG_PUBLIC_DEPS}
      PRIVATE mesocap_warnings ${ARG_PRIVATE_DEPS})
    if(MESOCAP_PRECOMPILE_HEADERS)
      target_link_libraries(mesocap_${name} PRIVATE Eigen3::Eigen nlohmann_json::nlohmann_json)
      target_precompile_headers(mesocap_${name} PRIVATE ${MESOCAP_PRECOMPILED_HEADERS})
    endif()
  else()
    add_library(mesocap_${name} INTERFACE)
    target_include_directories(mesocap_${name} INTERFACE ${PROJECT_SOURCE_DIR})
    target_link_libraries(mesocap_${name} INTERFACE ${ARG_PUBLIC_DEPS})
  endif()
  add_library(mesocap::${name} ALIAS mesocap_${name})
endfunction()

# What every test binary is compiled with.
add_library(mesocap_test_flags INTERFACE)
target_link_libraries(mesocap_test_flags INTERFACE mesocap_warnings)
target_include_directories(mesocap_test_flags INTERFACE ${PROJECT_SOURCE_DIR})
# Tests find shipped data (rig descriptions, scenes) from the source tree.
target_compile_definitions(mesocap_test_flags INTERFACE MESOCAP_SOURCE_DIR="${PROJECT_SOURCE_DIR}")

# With MESOCAP_PRECOMPILE_HEADERS the test binaries share one precompiled
# header (GoogleTest and MESOCAP_PRECOMPILED_HEADERS), built from an empty
# generated file with the test binaries' own flags, as GCC requires of a
# header it reuses.
function(mesocap_test_precompiled_header)
  if(NOT MESOCAP_PRECOMPILE_HEADERS)
    return()
  endif()
  file(GENERATE OUTPUT ${PROJECT_BINARY_DIR}/mesocap_test_pch.cc
    CONTENT "// Compiles the test binaries' shared precompiled header.\n")
  add_library(mesocap_test_pch OBJECT ${PROJECT_BINARY_DIR}/mesocap_test_pch.cc)
  target_link_libraries(mesocap_test_pch PRIVATE mesocap_test_flags GTest::gtest GTest::gmock
    Eigen3::Eigen nlohmann_json::nlohmann_json)
  target_precompile_headers(mesocap_test_pch PRIVATE <gtest/gtest.h> ${MESOCAP_PRECOMPILED_HEADERS})
endfunction()

# mesocap_test(NAME SOURCES ... DEPS ... [LABELS ...] [ENVIRONMENT ...]
# [ONE_PROCESS] [RUN_SERIAL] [LAUNCHER command...]): one
# GoogleTest binary, registered test by test with ctest; with ONE_PROCESS as
# one ctest test instead, for a suite whose fixture (SetUpTestSuite) is
# expensive and would otherwise be rebuilt in every test's process, and for
# a binary of many fast tests (starting a test process costs about 0.5 s of
# CPU, 1 s under the sanitizers: the dynamic loader resolves OpenImageIO's
# 260 libraries).
# RUN_SERIAL keeps other tests off the cores while it runs: for a test whose
# claim (frames on loopback arrive in time) a loaded host would falsify.
# The label `accuracy` marks end-to-end accuracy tests on the small rig (minutes of CPU in release),
# the label `browser` tests in headless Chromium (not our code, so not run under the sanitizers):
# they run in the release and debug presets; the sanitize preset leaves them
# out, since the code they run is covered there by the smaller tests. For the
# same reason it leaves out, by name, the camera calibration's hard cases
# (CameraCalibrationHardCases.*: minutes of Ceres and corner detection under
# the sanitizers, the same code as CameraCalibration.*), the statistics
# over noise seeds (*OverNoiseSeeds: one calibration repeated) and the chain
# without truth against the one with it (CalibratedChainCli.*: 5 minutes
# there; its commands run in the smaller CLI tests) and the CLI's kill -9
# trials (apps_kill_recovery_cli_test: 6 minutes there; the resume code runs
# under the sanitizers in the daemon's stop and restart tests).
# A test binary all of whose labels are in MESOCAP_UNBUILT_TEST_LABELS is not
# built with `all` nor registered with ctest: the sanitize preset leaves out
# the labels its suite does not run, and with them minutes of compiling.
set(MESOCAP_UNBUILT_TEST_LABELS "" CACHE STRING "Labels of test binaries left out of the build and of ctest")
function(mesocap_test name)
  cmake_parse_arguments(ARG "ONE_PROCESS;RUN_SERIAL" "" "SOURCES;DEPS;LABELS;ENVIRONMENT;LAUNCHER" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  mesocap_unity_build(${name})
  # LAUNCHER runs the binary, for discovery and for each test (CTest takes
  # it from CROSSCOMPILING_EMULATOR).
  if(ARG_LAUNCHER)
    set_target_properties(${name} PROPERTIES CROSSCOMPILING_EMULATOR "${ARG_LAUNCHER}")
  endif()
  target_link_libraries(${name} PRIVATE mesocap_test_flags ${ARG_DEPS} GTest::gtest_main GTest::gmock)
  if(MESOCAP_PRECOMPILE_HEADERS)
    target_precompile_headers(${name} REUSE_FROM mesocap_test_pch)
  endif()
  set(unbuilt FALSE)
  if(ARG_LABELS)
    set(unbuilt TRUE)
    foreach(label IN LISTS ARG_LABELS)
      if(NOT label IN_LIST MESOCAP_UNBUILT_TEST_LABELS)
        set(unbuilt FALSE)
      endif()
    endforeach()
  endif()
  if(unbuilt)
    set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL TRUE)
    return()
  endif()
  set(properties "")
  if(ARG_LABELS)
    list(APPEND properties LABELS "${ARG_LABELS}")
  endif()
  if(ARG_ENVIRONMENT)
    list(APPEND properties ENVIRONMENT "${ARG_ENVIRONMENT}")
  endif()
  if(ARG_RUN_SERIAL)
    list(APPEND properties RUN_SERIAL TRUE)
  endif()
  if(ARG_ONE_PROCESS)
    add_test(NAME ${name} COMMAND ${ARG_LAUNCHER} $<TARGET_FILE:${name}>)
    # A whole binary is longer than one of its tests: without timings of an
    # earlier run (a fresh build) ctest starts these first, so that the
    # longest do not run alone at the end.
    set_tests_properties(${name} PROPERTIES COST 60 ${properties})
  elseif(properties)
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${properties})
  else()
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60)
  endif()
endfunction()
