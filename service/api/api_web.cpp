// The dashboard: GET / is its page, GET /ui/{name} its scripts and style. They are public
// (the page asks for the token, keeps it in the browser's session storage and sends it as
// a bearer token with every API call); no data is in them. A strict Content-Security-Policy
// lets the page load only its own files and talk only to this daemon, so a script
// injected through data shown on the page could not run or send the token elsewhere.
#include "service/api/service_context.h"
#include "service/api/web_assets.h"

namespace camlab::service {

namespace {

const WebAsset* find_asset(std::string_view name) {
  for (const WebAsset& asset : web_assets())
    if (asset.name == name) return &asset;
  return nullptr;
}

ApiResponse asset_response(const WebAsset& asset) {
  ApiResponse response;
  response.content_type = std::string(asset.content_type);
  response.body = std::string(asset.bytes);
  response.headers = {
      {"Content-Security-Policy",
       "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; "
       "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"},
      {"X-Content-Type-Options", "nosniff"},
      {"Referrer-Policy", "no-referrer"}};
  return response;
}

}  // namespace

void add_web_routes(Router& router, const ServiceContext&) {
  Route page{"GET", "/",
             "The dashboard (docs/dashboard.md): live view, histogram, controls, "
             "captures, jobs and plots",
             [](const ApiRequest&, const PathParams&, Reply reply) {
               const WebAsset* index = find_asset("index.html");
               if (!index) return reply(error_response("internal", "the dashboard is missing"));
               reply(asset_response(*index));
             }};
  page.is_public = true;
  router.add(std::move(page));
  Route files{
      "GET", "/ui/{name}", "The dashboard's scripts and style",
      [](const ApiRequest&, const PathParams& params, Reply reply) {
        const WebAsset* asset = find_asset(params.at("name"));
        if (!asset || asset->name == "index.html")
          return reply(error_response(
              "not_found", "the dashboard has no file '" + params.at("name").substr(0, 100) + "'"));
        reply(asset_response(*asset));
      }};
  files.is_public = true;
  router.add(std::move(files));
}

}  // namespace camlab::service
