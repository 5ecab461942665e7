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
