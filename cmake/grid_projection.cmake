# Grid-to-image projection (issue 5): KITTI calibration readers and the projection in the core,
# DynamicGrid/CameraInfo/ProjectedGrid conversions in the ROS layer, the grid_projection nodelet,
# its tests and its benchmark.
target_sources(grid_vision_fusion_core PRIVATE
  src/core/grid_projection.cpp
  src/core/kitti_calibration.cpp)
target_sources(grid_vision_fusion_ros PRIVATE src/ros/projection_conversions.cpp)
target_sources(grid_vision_fusion_nodelets PRIVATE src/nodelets/grid_projection_nodelet.cpp)

# Benchmark (Google Benchmark): built by default, never run as a test.
if(benchmark_FOUND)
  add_executable(bench_grid_projection bench/bench_grid_projection.cpp)
  target_link_libraries(bench_grid_projection grid_vision_fusion_core benchmark::benchmark)
  target_compile_options(bench_grid_projection PRIVATE ${GVF_WARNINGS})
  gvf_rosrun_executable(bench_grid_projection)
endif()

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_grid_projection
    test/core/test_grid_projection.cpp
    test/core/test_kitti_calibration.cpp)
  target_link_libraries(test_grid_projection grid_vision_fusion_core ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_grid_projection PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_grid_projection PRIVATE
    GVF_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data")

  add_rostest_gtest(test_grid_projection_nodelet test/rostest/grid_projection_nodelet.test
    test/rostest/test_grid_projection_nodelet.cpp)
  target_link_libraries(test_grid_projection_nodelet ${catkin_LIBRARIES})
  target_compile_options(test_grid_projection_nodelet PRIVATE ${GVF_WARNINGS})
  add_dependencies(test_grid_projection_nodelet grid_vision_fusion_nodelets
    ${PROJECT_NAME}_generate_messages_cpp)

  roslaunch_add_file_check(launch/grid_projection.launch manager:=manager)
endif()
