# The scenario suite (issue 11): scripts/evaluate_suite.sh scores the scenarios of
# config/scenarios/ through the whole chain (doc/scenario_suite.md). In the test command: the
# unit tests of the summary script and of the suite script's error handling.
if(CATKIN_ENABLE_TESTING)
  set(GVF_SUITE_TOOLS make_synthetic_drive kitti_to_bag run_pipeline evaluate)

  set(GVF_SUITE_RESULT ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/python-test_suite_report.xml)
  catkin_run_tests_target("python" "test_suite_report" "python-test_suite_report.xml"
    COMMAND "${PYTHON_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/test/scripts/test_suite_report.py --junit ${GVF_SUITE_RESULT} --devel ${CATKIN_DEVEL_PREFIX}"
    DEPENDENCIES ${GVF_SUITE_TOOLS})

endif()
