# The offline runner (issue 7, `run_pipeline`): parameters from the nodelets' YAML files without
# a master (ParamSource), the glue the nodelets and the runner share (stages), the Pipeline in
# the ROS layer, the thin tool, the YAML parameter test and the rostest comparing the runner with
# the nodelet chain.
target_sources(grid_vision_fusion_ros PRIVATE src/ros/stages.cpp src/ros/pipeline.cpp)
target_link_libraries(grid_vision_fusion_ros PRIVATE ${YAML_CPP_LIBRARIES})

add_executable(run_pipeline tools/run_pipeline.cpp)
target_link_libraries(run_pipeline grid_vision_fusion_ros)
target_compile_options(run_pipeline PRIVATE ${GVF_WARNINGS})
add_dependencies(run_pipeline ${PROJECT_NAME}_generate_messages_cpp)
gvf_rosrun_executable(run_pipeline)

if(CATKIN_ENABLE_TESTING)
  catkin_add_gtest(test_param_source test/ros/test_param_source.cpp)
  target_link_libraries(test_param_source grid_vision_fusion_ros ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_param_source PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_param_source PRIVATE GVF_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")

  add_rostest_gtest(test_pipeline_equivalence test/rostest/pipeline_equivalence.test
    test/rostest/test_pipeline_equivalence.cpp)
  target_link_libraries(test_pipeline_equivalence grid_vision_fusion_ros ${catkin_LIBRARIES})
  target_compile_options(test_pipeline_equivalence PRIVATE ${GVF_WARNINGS})
  target_compile_definitions(test_pipeline_equivalence PRIVATE GVF_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  add_dependencies(test_pipeline_equivalence grid_vision_fusion_nodelets ${PROJECT_NAME}_generate_messages_cpp)
endif()
