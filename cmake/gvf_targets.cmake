# One helper per kind of target, so that every target of the package gets the same standard,
# warnings, include paths and message dependencies, and every test is registered the same way.
#
#   gvf_library(<name> SOURCES <src>... [LINK <target>...])
#   gvf_executable(<name> SOURCES <src>... [LINK <target>...] [ROSRUN])
#   gvf_gtest(<name> SOURCES <src>... [LINK <target>...] [DEFINITIONS <NAME=value>...] [DEPENDS <target>...])
#   gvf_rostest(<name> LAUNCH <file.test> SOURCES <src>... [LINK <target>...] [DEPENDS <target>...])

# Warnings are errors on our own targets only.
set(GVF_WARNINGS -Wall -Wextra -Werror)

# scripts/run_tests.sh --sanitize: AddressSanitizer + UndefinedBehaviorSanitizer on every target
# of the package (undefined behaviour aborts instead of printing and going on). The
# instrumentation makes gcc's maybe-uninitialized analysis report false positives in Boost's
# headers, so that warning is off in this build only.
option(GVF_SANITIZE "Build with AddressSanitizer and UndefinedBehaviorSanitizer" OFF)
if(GVF_SANITIZE)
  set(GVF_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -g)
  list(APPEND GVF_WARNINGS -Wno-maybe-uninitialized)
endif()

# scripts/fuzz.sh: clang only. Every target of the package gets libFuzzer's coverage
# instrumentation with AddressSanitizer and UndefinedBehaviorSanitizer (-O1 -g, as libFuzzer's
# documentation advises), and fuzz/fuzz.cmake adds one fuzz_<harness> executable per harness,
# linked with -fsanitize=fuzzer.
option(GVF_FUZZ "Build the libFuzzer harnesses of fuzz/ (clang; scripts/fuzz.sh)" OFF)
if(GVF_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "GVF_FUZZ needs clang (libFuzzer): configure with CC=clang-14 CXX=clang++-14")
  endif()
  if(GVF_SANITIZE)
    message(FATAL_ERROR "GVF_FUZZ brings its own sanitizers: leave GVF_SANITIZE off")
  endif()
  set(GVF_SANITIZER_FLAGS -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
    -fno-omit-frame-pointer -g -O1)
endif()

function(_gvf_common target)
  target_compile_options(${target} PRIVATE ${GVF_WARNINGS} ${GVF_SANITIZER_FLAGS})
  target_link_options(${target} PRIVATE ${GVF_SANITIZER_FLAGS})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CATKIN_GLOBAL_INCLUDE_DESTINATION}>)
  target_include_directories(${target} SYSTEM PUBLIC ${EIGEN3_INCLUDE_DIRS} ${OpenCV_INCLUDE_DIRS}
    ${catkin_INCLUDE_DIRS})
  if(TARGET ${PROJECT_NAME}_generate_messages_cpp)
    add_dependencies(${target} ${PROJECT_NAME}_generate_messages_cpp ${PROJECT_NAME}_gencfg)
  endif()
endfunction()

function(gvf_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINK" ${ARGN})
  add_library(${name} ${ARG_SOURCES})
  _gvf_common(${name})
  target_link_libraries(${name} PUBLIC ${ARG_LINK})
endfunction()

# ROSRUN: `rosrun grid_vision_fusion <name>` in the devel space and once installed.
function(gvf_executable name)
  cmake_parse_arguments(ARG "ROSRUN" "" "SOURCES;LINK" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  _gvf_common(${name})
  target_link_libraries(${name} ${ARG_LINK})
  if(ARG_ROSRUN)
    set_target_properties(${name} PROPERTIES
      RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
    install(TARGETS ${name} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
  endif()
endfunction()

# Every gtest knows where the sources (GVF_SOURCE_DIR) and the test data (GVF_TEST_DATA_DIR) are.
function(gvf_gtest name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINK;DEFINITIONS;DEPENDS" ${ARGN})
  catkin_add_gtest(${name} ${ARG_SOURCES})
  _gvf_common(${name})
  target_link_libraries(${name} ${ARG_LINK} ${GTEST_MAIN_LIBRARIES})
  target_compile_definitions(${name} PRIVATE GVF_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    GVF_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/test/data" ${ARG_DEFINITIONS})
  if(ARG_DEPENDS)
    add_dependencies(${name} ${ARG_DEPENDS})
  endif()
endfunction()

# A rostest: a gtest node run by rostest against the nodelets of the plugin library.
function(gvf_rostest name)
  cmake_parse_arguments(ARG "" "LAUNCH" "SOURCES;LINK;DEPENDS" ${ARGN})
  add_rostest_gtest(${name} ${ARG_LAUNCH} ${ARG_SOURCES})
  _gvf_common(${name})
  target_link_libraries(${name} ${ARG_LINK} ${catkin_LIBRARIES})
  target_compile_definitions(${name} PRIVATE GVF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  add_dependencies(${name} grid_vision_fusion_nodelets ${ARG_DEPENDS})
endfunction()
