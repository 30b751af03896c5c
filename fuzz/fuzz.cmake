# The libFuzzer harnesses (-DGVF_FUZZ=ON with clang; scripts/fuzz.sh drives this build): one
# executable fuzz_<harness> in ${CMAKE_BINARY_DIR}/fuzz per fuzz/<folder>/fuzz_<harness>.cpp (a
# folder per package folder whose parsers they feed: detection, kitti, ros, simulation), and the
# target gvf_fuzz that builds them all. A harness is linked with the package libraries whose
# headers it includes: grid_vision_fusion/<folder>/... -> the library of src/<folder>/.
set(GVF_FUZZ_LIBRARY_cli grid_vision_fusion_cli)
set(GVF_FUZZ_LIBRARY_detection grid_vision_fusion_core)
set(GVF_FUZZ_LIBRARY_fusion grid_vision_fusion_core)
set(GVF_FUZZ_LIBRARY_grid grid_vision_fusion_core)
set(GVF_FUZZ_LIBRARY_projection grid_vision_fusion_core)
set(GVF_FUZZ_LIBRARY_kitti grid_vision_fusion_kitti)
set(GVF_FUZZ_LIBRARY_evaluation grid_vision_fusion_evaluation)
set(GVF_FUZZ_LIBRARY_simulation grid_vision_fusion_simulation)
set(GVF_FUZZ_LIBRARY_ros grid_vision_fusion_ros)
set(GVF_FUZZ_LIBRARY_ros_stages grid_vision_fusion_ros)
set(GVF_FUZZ_LIBRARY_ros_sync grid_vision_fusion_ros)
set(GVF_FUZZ_LIBRARY_offline grid_vision_fusion_offline)

file(GLOB GVF_FUZZ_HARNESS_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/fuzz/*/fuzz_*.cpp)
add_custom_target(gvf_fuzz)
foreach(source ${GVF_FUZZ_HARNESS_SOURCES})
  get_filename_component(harness ${source} NAME_WE)
  file(RELATIVE_PATH source_path ${PROJECT_SOURCE_DIR} ${source})
  file(STRINGS ${source} includes REGEX "^#include \"grid_vision_fusion/[a-z_]+/")
  set(libraries)
  foreach(line ${includes})
    string(REGEX REPLACE "^#include \"grid_vision_fusion/([a-z_]+)/.*" "\\1" folder "${line}")
    if(NOT DEFINED GVF_FUZZ_LIBRARY_${folder})
      message(FATAL_ERROR "${source_path} includes grid_vision_fusion/${folder}/: "
        "name the library of that folder in fuzz/fuzz.cmake (GVF_FUZZ_LIBRARY_${folder})")
    endif()
    list(APPEND libraries ${GVF_FUZZ_LIBRARY_${folder}})
  endforeach()
  if(libraries)
    list(REMOVE_DUPLICATES libraries)
  endif()
  gvf_executable(${harness} SOURCES ${source} LINK ${libraries})
  target_include_directories(${harness} PRIVATE ${PROJECT_SOURCE_DIR}/fuzz)  # fuzz_input.h
  target_compile_options(${harness} PRIVATE -fsanitize=fuzzer)
  target_link_options(${harness} PRIVATE -fsanitize=fuzzer)
  set_target_properties(${harness} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/fuzz)
  add_dependencies(gvf_fuzz ${harness})
endforeach()
