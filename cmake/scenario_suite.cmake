# The scenario suite (issue 11): scripts/evaluate_suite.sh scores the scenarios of
# config/scenarios/ through the whole chain (doc/scenario_suite.md). In the test command: the
# summary script's unit tests, and a short suite of two 7 s scenarios (test/data/suite_short)
# that fails when the motion classification falls below test/data/suite_short/thresholds.json.
if(CATKIN_ENABLE_TESTING)
  set(GVF_SUITE_TOOLS make_synthetic_drive kitti_to_bag run_pipeline evaluate)

  set(GVF_SUITE_RESULT ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/python-test_suite_report.xml)
  catkin_run_tests_target("python" "test_suite_report" "python-test_suite_report.xml"
    COMMAND "${PYTHON_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/test/scripts/test_suite_report.py --junit ${GVF_SUITE_RESULT} --devel ${CATKIN_DEVEL_PREFIX}"
    DEPENDENCIES ${GVF_SUITE_TOOLS})

  set(GVF_SUITE_RESULT ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/suite-scenario_suite_short.xml)
  catkin_run_tests_target("suite" "scenario_suite_short" "suite-scenario_suite_short.xml"
    COMMAND "${CMAKE_CURRENT_SOURCE_DIR}/scripts/evaluate_suite.sh --devel ${CATKIN_DEVEL_PREFIX} --jobs 2 --scenario-dir ${CMAKE_CURRENT_SOURCE_DIR}/test/data/suite_short --thresholds ${CMAKE_CURRENT_SOURCE_DIR}/test/data/suite_short/thresholds.json --output ${CMAKE_CURRENT_BINARY_DIR}/scenario_suite_short --junit ${GVF_SUITE_RESULT}"
    DEPENDENCIES ${GVF_SUITE_TOOLS})
endif()
