# YOLO detector (issue 4): core detector, KITTI label reader, detection replay, ROS
# conversions, the grid_vision_fusion/yolo_detector nodelet, its tests and its benchmark.
target_sources(grid_vision_fusion_core PRIVATE
  src/core/yolo_detector.cpp
  src/core/detection_replay.cpp
  src/core/kitti_labels.cpp)
target_sources(grid_vision_fusion_ros PRIVATE src/ros/detector_conversions.cpp)
target_sources(grid_vision_fusion_nodelets PRIVATE src/nodelets/yolo_detector_nodelet.cpp)

# Benchmark: the real YOLOv3 / YOLOv3-tiny architectures with random weights (built, not run
# as a test). Google Benchmark from Debian's libbenchmark-dev.
if(benchmark_FOUND)
  add_executable(bench_yolo bench/bench_yolo.cpp)
  target_link_libraries(bench_yolo grid_vision_fusion_core benchmark::benchmark)
  target_compile_options(bench_yolo PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(bench_yolo PRIVATE
    GVF_YOLO_CFG_DIR="${CMAKE_CURRENT_SOURCE_DIR}/models/yolo")
  gvf_rosrun_executable(bench_yolo)
endif()

if(CATKIN_ENABLE_TESTING)
  # The tiny Darknet model writer, shared by the core tests and the rostest.
  add_library(gvf_tiny_darknet STATIC EXCLUDE_FROM_ALL test/core/tiny_darknet.cpp)
  target_compile_options(gvf_tiny_darknet PRIVATE ${GVF_WARNINGS})
  set_target_properties(gvf_tiny_darknet PROPERTIES POSITION_INDEPENDENT_CODE ON)

  catkin_add_gtest(test_yolo_core
    test/core/test_yolo_detector.cpp
    test/core/test_yolo_kitti_labels.cpp
    test/core/test_yolo_detection_replay.cpp)
  target_link_libraries(test_yolo_core grid_vision_fusion_core gvf_tiny_darknet ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_yolo_core PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_yolo_core PRIVATE GVF_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data"
    GVF_MODEL_DIR="${CMAKE_CURRENT_SOURCE_DIR}/models/yolo")

  add_rostest_gtest(test_yolo_detector_nodelet test/rostest/yolo_detector_nodelet.test
    test/rostest/test_yolo_detector_nodelet.cpp)
  target_link_libraries(test_yolo_detector_nodelet gvf_tiny_darknet ${catkin_LIBRARIES})
  target_compile_options(test_yolo_detector_nodelet PRIVATE ${GVF_WARNINGS})
  add_dependencies(test_yolo_detector_nodelet grid_vision_fusion_nodelets ${PROJECT_NAME}_generate_messages_cpp)

  add_rostest_gtest(test_yolo_replay_nodelet test/rostest/yolo_replay_nodelet.test
    test/rostest/test_yolo_replay_nodelet.cpp)
  target_link_libraries(test_yolo_replay_nodelet ${catkin_LIBRARIES})
  target_compile_options(test_yolo_replay_nodelet PRIVATE ${GVF_WARNINGS})
  add_dependencies(test_yolo_replay_nodelet grid_vision_fusion_nodelets ${PROJECT_NAME}_generate_messages_cpp)

  roslaunch_add_file_check(launch/yolo_detector.launch manager:=manager)
endif()
