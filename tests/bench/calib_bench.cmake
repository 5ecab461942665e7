# Calibration speed against error (docs/measuring.md): a bench executable, not a test.
add_executable(calib_bench ${CMAKE_CURRENT_LIST_DIR}/calib_bench.cpp)
target_link_libraries(calib_bench PRIVATE camlab_calib mrcal::mrcal opencv_calib3d)
target_include_directories(calib_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)

# Projection uncertainty against the truth and against mrcal's Python (prints tables).
add_executable(calib_bench_uncertainty ${CMAKE_CURRENT_LIST_DIR}/calib_bench_uncertainty.cpp)
target_link_libraries(calib_bench_uncertainty PRIVATE camlab_calib nlohmann_json::nlohmann_json opencv_calib3d)
target_include_directories(calib_bench_uncertainty PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)
target_compile_definitions(calib_bench_uncertainty PRIVATE CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")

# Corner detection against the virtual camera's truth, and calibrate()'s detect/solve split.
add_executable(calib_detect_bench ${CMAKE_CURRENT_LIST_DIR}/calib_detect_bench.cpp)
target_link_libraries(calib_detect_bench PRIVATE camlab_calib nlohmann_json::nlohmann_json)

# ChArUco corners against the virtual camera's truth, stage by stage.
add_executable(charuco_detect_bench ${CMAKE_CURRENT_LIST_DIR}/charuco_detect_bench.cpp)
target_link_libraries(charuco_detect_bench PRIVATE camlab_calib mrcal::mrcal nlohmann_json::nlohmann_json)

# The guided calibration loop against random poses: views to a worst-uncertainty target,
# and the time of a suggestion (docs/BENCHMARKS.md).
add_executable(guided_calibration_bench ${CMAKE_CURRENT_LIST_DIR}/guided_calibration_bench.cpp)
target_link_libraries(guided_calibration_bench PRIVATE camlab_calib mrcal::mrcal opencv_calib3d)
target_include_directories(guided_calibration_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib ${PROJECT_SOURCE_DIR})

# Partial chessboard views with OpenCV 4.6's circle markers, against the virtual camera's
# truth: OpenCV's own marker detection, its grid named by camlab's marker reading, and
# camlab's detector (docs/calibration.md).
add_executable(marker_chessboard_bench ${CMAKE_CURRENT_LIST_DIR}/marker_chessboard_bench.cpp)
target_link_libraries(marker_chessboard_bench PRIVATE camlab_calib camlab_mock_device
                      nlohmann_json::nlohmann_json)
target_compile_definitions(marker_chessboard_bench PRIVATE CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")

# Partial views at the imager's edges against their whole-board twins, rendered, for a
# ChArUco board and a marker chessboard: border coverage and the error at the corners.
add_executable(partial_views_bench ${CMAKE_CURRENT_LIST_DIR}/partial_views_bench.cpp)
target_link_libraries(partial_views_bench PRIVATE camlab_calib camlab_mock_device mrcal::mrcal
                      nlohmann_json::nlohmann_json)
target_include_directories(partial_views_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)
target_compile_definitions(partial_views_bench PRIVATE CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")

# Rig calibration (calib/rig/): extrinsics' error against their stated sigma over 50 noise
# seeds, a triangulated range's, and the solve time of a 4-camera ring.
add_executable(rig_bench ${CMAKE_CURRENT_LIST_DIR}/rig_bench.cpp)
target_link_libraries(rig_bench PRIVATE camlab_calib mrcal::mrcal opencv_calib3d)
target_include_directories(rig_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/unit/calib)
