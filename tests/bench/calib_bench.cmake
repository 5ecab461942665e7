# Calibration speed against error (calibration issue): a bench executable, not a test.
add_executable(calib_bench ${CMAKE_CURRENT_LIST_DIR}/calib_bench.cpp)
target_link_libraries(calib_bench PRIVATE camlab_calib mrcal::mrcal opencv_calib3d)
target_include_directories(calib_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)
