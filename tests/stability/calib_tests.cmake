# Calibration hard cases: synthetic corners from a known lens, and the end-to-end
# acceptance test on rendered views.
camlab_add_test(calib_stability_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/calib_stability_test.cpp
  LIBS camlab_calib mrcal::mrcal
  LABELS stability)
target_include_directories(calib_stability_tests PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)

camlab_add_test(calib_end_to_end_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/calib_end_to_end_test.cpp
  LIBS camlab_calib mrcal::mrcal nlohmann_json::nlohmann_json
  LABELS stability)
target_include_directories(calib_end_to_end_tests PRIVATE ${PROJECT_SOURCE_DIR})
add_dependencies(calib_end_to_end_tests camlab_cli)

# The README's 40 example views, rendered in process: horizontal and vertical FOV against
# the truth's (about 25 s on 2 cores).
camlab_add_test(calib_fov_example_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/calib_fov_example_test.cpp
  LIBS camlab_calib camlab_mock_device mrcal::mrcal nlohmann_json::nlohmann_json
  LABELS stability)
target_include_directories(calib_fov_example_tests PRIVATE ${PROJECT_SOURCE_DIR})

# Partial views at the imager's edges against the same views moved until the board is
# whole: border coverage and the projection error at the imager's corners (seconds).
camlab_add_test(calib_partial_views_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/calib_partial_views_test.cpp
  LIBS camlab_calib mrcal::mrcal
  LABELS stability)
target_include_directories(calib_partial_views_tests PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)
