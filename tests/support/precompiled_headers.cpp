// The targets that compile the shared precompiled headers of the test executables
// (tests/CMakeLists.txt) and of the benchmarks (tests/bench/CMakeLists.txt): GoogleTest,
// nlohmann/json and OpenCV's core are parsed once for the whole suite, not once a file.

int main() { return 0; }
