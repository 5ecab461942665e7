# Speed against error for src/analysis (prints tables; never a pass/fail test).
add_executable(analysis_bench ${CMAKE_CURRENT_SOURCE_DIR}/analysis_bench.cpp)
target_link_libraries(analysis_bench PRIVATE camlab camlab_mock_device)
target_compile_definitions(analysis_bench PRIVATE CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
