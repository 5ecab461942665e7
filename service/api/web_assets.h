// The dashboard's static files (service/web/), built into camlabd by
// cmake/embed_files.cmake, so the daemon serves its page with nothing installed beside it
// and no network (no CDN: camera stations are often offline).
#pragma once

#include <span>
#include <string_view>

namespace camlab::service {

struct WebAsset {
  std::string_view name;          // "app.js", as under service/web/
  std::string_view content_type;  // "text/javascript; charset=utf-8"
  std::string_view bytes;
};

std::span<const WebAsset> web_assets();

}  // namespace camlab::service
