// The virtual camera's camera spec (mock_device/spec/camera_spec.h): JSON from a file
// (`camlab render --camera`, `camlab vcam`) or a request. Text that is not JSON is the
// JSON library's business; the harness fuzzes what parse_camera_spec does with a document.
#include <cstddef>
#include <cstdint>

#include <nlohmann/json.hpp>

#include "mock_device/spec/camera_spec.h"
#include "tests/fuzz/fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto json = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  auto spec = camlab::mock::parse_camera_spec(json);
  if (!spec) camlab::fuzz::check_error(spec.error());
  return 0;
}
