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
#
# LABELS place a binary's tests in the tiers (docs/DEVELOPING.md):
#   quick     the inner loop: each library's unit tests and one whole chain
#             on the tiny rig (ctest --preset quick);
#   sanitize  also run under the sanitizers: what reads files or network
#             input, the daemon, the drivers (the sanitize preset runs
#             `quick` tests only where they are `sanitize` too);
#   accuracy  end-to-end accuracy on the small and paper rigs (minutes of CPU);
#   served    cameras served over GigE Vision on loopback, in a network
#             namespace of the test's own (mostly waiting on the network:
#             scripts/test.sh runs three at a time);
#   browser   the daemon's status page in headless Chromium.
# The release suite is every test but `served` and `browser`, which
# scripts/test.sh runs after it.
# With MESOCAP_BUILT_TEST_LABELS set, a test binary none of whose labels is
# in it is not built with `all` nor registered with ctest: the sanitize
# preset compiles only what its suite runs.
set(MESOCAP_BUILT_TEST_LABELS "" CACHE STRING "Labels of the test binaries to build (empty: all)")
set(MESOCAP_TEST_TIERS quick sanitize accuracy served browser)
function(mesocap_test name)
  cmake_parse_arguments(ARG "ONE_PROCESS;RUN_SERIAL" "" "SOURCES;DEPS;LABELS;ENVIRONMENT;LAUNCHER" ${ARGN})
  foreach(label IN LISTS ARG_LABELS)
    if(NOT label IN_LIST MESOCAP_TEST_TIERS)
      message(FATAL_ERROR "test ${name}: label '${label}' is none of the tiers (${MESOCAP_TEST_TIERS})")
    endif()
  endforeach()
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
  if(MESOCAP_BUILT_TEST_LABELS)
    set(built FALSE)
    foreach(label IN LISTS ARG_LABELS)
      if(label IN_LIST MESOCAP_BUILT_TEST_LABELS)
        set(built TRUE)
      endif()
    endforeach()
    if(NOT built)
      set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL TRUE)
      return()
    endif()
  endif()
  set(properties "")
  if(ARG_LABELS)
    # A binary in several tiers carries one label that names them joined
    # by '-' ("quick-sanitize"): ctest matches a label filter as a regular
    # expression, so `-L quick` and `-L sanitize` both find it, and
    # gtest_discover_tests cannot pass a list-valued property.
    list(JOIN ARG_LABELS "-" labels)
    list(APPEND properties LABELS "${labels}")
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
