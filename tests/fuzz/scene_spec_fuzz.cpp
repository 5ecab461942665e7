// The virtual camera's scene spec (mock_device/spec/scene_spec.h): targets, poses,
// illumination, as JSON from a file or a request.
#include <cstddef>
#include <cstdint>

#include <nlohmann/json.hpp>

#include "mock_device/spec/scene_spec.h"
#include "tests/fuzz/fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto json = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  auto spec = camlab::mock::parse_scene_spec(json);
  if (!spec) camlab::fuzz::check_error(spec.error());
  return 0;
}
