#include "render_settings.h"

#include <stdexcept>

#include "mock_device/render/render_capture.h"

namespace camlab::cli {

mock::RenderSettings settings_from_sets(const CommandErrors& errors, const mock::Renderer& renderer,
                                        const std::vector<std::string>& sets) {
  mock::RenderSettings settings = renderer.default_settings();
  for (const auto& set : sets) {
    const auto eq = set.find('=');
    if (eq == std::string::npos)
      errors.fail("invalid_argument", "--set '" + set + "' must be name=value");
    double value = 0;
    try {
      size_t used = 0;
      value = std::stod(set.substr(eq + 1), &used);
      if (used != set.size() - eq - 1) throw std::invalid_argument(set);
    } catch (const std::exception&) {
      errors.fail("invalid_argument", "--set '" + set + "': the value is not a number");
    }
    if (Status ok = mock::apply_setting(renderer, set.substr(0, eq), value, &settings); !ok)
      errors.fail(ok.error().with_context("--set " + set + ": "));
  }
  return settings;
}

}  // namespace camlab::cli
