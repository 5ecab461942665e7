# Hard cases of docs/physics.md for src/analysis: right answer or a specific flag.
camlab_add_test(analysis_stability_test
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/analysis_stability_test.cpp
  LIBS camlab LABELS stability)
