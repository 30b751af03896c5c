# The dynamic occupancy grid (issue 3): filter core, ROS conversions, nodelet, tests, benchmark.
target_sources(grid_vision_fusion_core PRIVATE
  src/core/grid_map.cpp
  src/core/inverse_sensor_model.cpp
  src/core/dynamic_grid_filter.cpp)
target_sources(grid_vision_fusion_ros PRIVATE src/ros/grid_conversions.cpp)
target_sources(grid_vision_fusion_nodelets PRIVATE src/nodelets/dynamic_grid_nodelet.cpp)

# Box-world lidar simulator shared by the core tests and the benchmark (not installed).
add_library(gvf_box_world_lidar STATIC test/core/box_world_lidar.cpp)
target_include_directories(gvf_box_world_lidar SYSTEM PUBLIC ${EIGEN3_INCLUDE_DIRS})
target_compile_options(gvf_box_world_lidar PRIVATE ${GVF_WARNINGS})

if(benchmark_FOUND)
  add_executable(bench_dynamic_grid bench/bench_dynamic_grid.cpp)
  target_include_directories(bench_dynamic_grid PRIVATE test/core)
  target_link_libraries(bench_dynamic_grid grid_vision_fusion_core gvf_box_world_lidar benchmark::benchmark)
  target_compile_options(bench_dynamic_grid PRIVATE ${GVF_WARNINGS})
  gvf_rosrun_executable(bench_dynamic_grid)
endif()

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_grid_core
    test/core/test_grid_map.cpp
    test/core/test_grid_sensor_model.cpp
    test/core/test_grid_filter.cpp)
  target_link_libraries(test_grid_core grid_vision_fusion_core gvf_box_world_lidar ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_grid_core PRIVATE ${GVF_WARNINGS})

  add_rostest_gtest(test_dynamic_grid_nodelet test/rostest/dynamic_grid_nodelet.test
    test/rostest/test_dynamic_grid_nodelet.cpp)
  target_link_libraries(test_dynamic_grid_nodelet ${catkin_LIBRARIES})
  target_compile_options(test_dynamic_grid_nodelet PRIVATE ${GVF_WARNINGS})
  add_dependencies(test_dynamic_grid_nodelet grid_vision_fusion_nodelets ${PROJECT_NAME}_generate_messages_cpp)

  roslaunch_add_file_check(launch/dynamic_grid.launch manager:=manager)
endif()
