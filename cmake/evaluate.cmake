# Evaluation against KITTI ground truth (issue 7, the `evaluate` tool): ground truth from raw
# drives (tracklets + OXTS + calibration) and from label files with a motion column in the core,
# the DetectedObjectArray bag reader in the ROS layer, the tool, its tests.
target_sources(grid_vision_fusion_core PRIVATE src/core/kitti_ground_truth.cpp)
target_sources(grid_vision_fusion_ros PRIVATE src/ros/detection_bag.cpp)

add_executable(evaluate tools/evaluate.cpp)
target_link_libraries(evaluate grid_vision_fusion_ros)
target_compile_options(evaluate PRIVATE ${GVF_WARNINGS})
add_dependencies(evaluate ${PROJECT_NAME}_generate_messages_cpp)
gvf_rosrun_executable(evaluate)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_kitti_ground_truth
    test/core/test_kitti_ground_truth.cpp
    test/core/test_progress_bar.cpp)
  target_link_libraries(test_kitti_ground_truth grid_vision_fusion_core ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_kitti_ground_truth PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_kitti_ground_truth PRIVATE GVF_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data")

  # ROS layer: a bag written by the test, read back and evaluated (no master).
  catkin_add_gtest(test_evaluate_bag test/ros/test_evaluate_bag.cpp)
  target_link_libraries(test_evaluate_bag grid_vision_fusion_ros ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_evaluate_bag PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_evaluate_bag PRIVATE GVF_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data"
    GVF_EVALUATE_TOOL="$<TARGET_FILE:evaluate>")
  add_dependencies(test_evaluate_bag evaluate)
endif()
