# service_bench: camlabd's frames consumed and wall time for exposure brackets against the
# minimum, and status-request throughput and p99 latency with a capture running (wrk when
# installed, else a bounded C++ load client). Prints; never passes or fails on a time.
add_executable(service_bench ${CMAKE_CURRENT_SOURCE_DIR}/service_bench.cpp)
target_include_directories(service_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/integration/service)
target_link_libraries(service_bench PRIVATE nlohmann_json::nlohmann_json Threads::Threads)
target_compile_definitions(service_bench PRIVATE CAMLABD_PATH="$<TARGET_FILE:camlabd>")
add_dependencies(service_bench camlabd)

# hotplug_bench: unplug -> device_lost and replug -> available times, in-process and under
# `camlab vcam run` (V4L2 and libcamera), and a libcamera bracket's linearity. Prints only.
add_executable(hotplug_bench ${CMAKE_CURRENT_SOURCE_DIR}/hotplug_bench.cpp)
target_include_directories(hotplug_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/integration/service)
target_link_libraries(hotplug_bench PRIVATE nlohmann_json::nlohmann_json opencv_core
                                            opencv_imgproc opencv_imgcodecs GTest::gtest)
target_compile_definitions(hotplug_bench PRIVATE CAMLABD_PATH="$<TARGET_FILE:camlabd>"
                                                 CAMLAB_CLI_PATH="$<TARGET_FILE:camlab_cli>")
add_dependencies(hotplug_bench camlabd camlab_cli camlab_vcam_preload)
# sensor_rate_bench: 300-frame single captures and brackets through camlabd at 30 frames/s:
# frames kept, consumed against N + latency, dropped by the device and by camlabd.
add_executable(sensor_rate_bench ${CMAKE_CURRENT_SOURCE_DIR}/sensor_rate_bench.cpp)
target_include_directories(sensor_rate_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/integration/service)
target_link_libraries(sensor_rate_bench PRIVATE nlohmann_json::nlohmann_json Threads::Threads)
target_compile_definitions(sensor_rate_bench PRIVATE CAMLABD_PATH="$<TARGET_FILE:camlabd>"
                                                     CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_dependencies(sensor_rate_bench camlabd)
# status_load_bench: keep-alive status GETs from 16/64/256 connections, idle and during a
# 300-frame capture, and that capture's kept frames/s against the capture alone. Prints only.
add_executable(status_load_bench ${CMAKE_CURRENT_SOURCE_DIR}/status_load_bench.cpp)
target_include_directories(status_load_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/integration/service)
target_link_libraries(status_load_bench PRIVATE nlohmann_json::nlohmann_json Threads::Threads)
target_compile_definitions(status_load_bench PRIVATE CAMLABD_PATH="$<TARGET_FILE:camlabd>"
                                                     CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_dependencies(status_load_bench camlabd)
# live_view_bench: the dashboard's live view at its cap while 300-frame captures run on the
# same camera, and those captures' kept frames against the captures alone. Prints only.
add_executable(live_view_bench ${CMAKE_CURRENT_SOURCE_DIR}/live_view_bench.cpp)
target_include_directories(live_view_bench PRIVATE ${PROJECT_SOURCE_DIR}/tests/integration/service)
target_link_libraries(live_view_bench PRIVATE nlohmann_json::nlohmann_json Threads::Threads)
target_compile_definitions(live_view_bench PRIVATE CAMLABD_PATH="$<TARGET_FILE:camlabd>"
                                                   CAMLAB_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_dependencies(live_view_bench camlabd)
