# KITTI raw drive → ROS bag (issue 6): the bag writer in the ROS layer, the kitti_to_bag tool
# (`rosrun grid_vision_fusion kitti_to_bag`) and its tests (rosbag needs no master).
target_sources(grid_vision_fusion_ros PRIVATE src/ros/kitti_bag_writer.cpp)

add_executable(kitti_to_bag tools/kitti_to_bag.cpp)
target_link_libraries(kitti_to_bag grid_vision_fusion_ros)
target_compile_options(kitti_to_bag PRIVATE ${GVF_WARNINGS})
gvf_rosrun_executable(kitti_to_bag)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_kitti_bag_writer test/ros/test_kitti_bag_writer.cpp)
  target_link_libraries(test_kitti_bag_writer grid_vision_fusion_ros ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_kitti_bag_writer PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_kitti_bag_writer PRIVATE
    GVF_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data"
    GVF_KITTI_TO_BAG="$<TARGET_FILE:kitti_to_bag>")
  add_dependencies(test_kitti_bag_writer kitti_to_bag)
endif()
