# Hard cases of docs/physics.md for src/analysis: right answer or a specific flag.
camlab_add_test(analysis_stability_test
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/analysis_stability_test.cpp
  LIBS camlab LABELS stability)
# Hard cases of light fields: right answer or a specific error or flag, on the virtual
# camera's light fields.
camlab_add_test(lightfield_stability_test
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/lightfield_stability_test.cpp
  LIBS camlab camlab_mock_device LABELS stability)
target_include_directories(lightfield_stability_test PRIVATE
  ${PROJECT_SOURCE_DIR}/tests/unit/analysis ${PROJECT_SOURCE_DIR}/tests/unit/mock_device)
