// Every file a job wrote, to download byte for byte: GET /v1/jobs/{id}/files lists them
// (path relative to the job's folder, bytes, the URL), GET /v1/jobs/{id}/files/{name} and
// .../files/{dir}/{name} serve one (a job writes into its folder and one level of
// subfolders, plots/; the router takes no '/' inside a segment). Captures
// list their frames, sidecars, manifest and journal; calibrations their .cameramodel,
// report.json, corners and plots; analyses their plots. Only regular files under the job's
// folder, reached through real folders: a symlink or a ".." is refused, never followed.
#include <algorithm>
#include <filesystem>

#include "service/api/api_lookup.h"
#include "service/api/router.h"
#include "service/api/service_context.h"

namespace camlab::service {

namespace {

namespace fs = std::filesystem;

// A job folder holds at most this many files to list (a long capture: 2 a frame).
constexpr size_t kMaxListedFiles = 20000;

// A download is the file as stored: JSON files too go out as octet-stream, which the
// router's hiding of the data folder in JSON answers leaves alone (a report written there
// names its files by their full paths, as `camlab calibrate` writes them).
std::string content_type_of(const fs::path& path) {
  return path.extension() == ".png" ? "image/png" : "application/octet-stream";
}

// The path's segments percent-encoded, '/' kept between them.
std::string url_path(const std::string& relative) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : relative) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~' || c == '/') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

void list_files(const ServiceContext& context, const PathParams& params, Reply reply) {
  auto job = find_job(context, params, reply);
  if (!job) return;
  nlohmann::json files = nlohmann::json::array();
  const fs::path dir = context.data_dir / job->folder;
  std::error_code ec;
  if (!job->folder.empty() && within_data_dir(context.data_dir, job->folder) &&
      fs::is_directory(dir, ec)) {
    std::vector<std::pair<std::string, uintmax_t>> found;
    for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (found.size() >= kMaxListedFiles) break;
      if (it.depth() >= 1) it.disable_recursion_pending();  // its folder and one level below
      const auto status = it->symlink_status(ec);
      if (ec || !fs::is_regular_file(status)) continue;  // folders, symlinks, devices
      found.emplace_back(fs::relative(it->path(), dir, ec).string(), it->file_size(ec));
    }
    std::sort(found.begin(), found.end());
    const std::string base = "/v1/jobs/" + std::to_string(job->id) + "/files/";
    for (const auto& [relative, bytes] : found)
      files.push_back({{"path", relative}, {"bytes", bytes}, {"url", base + url_path(relative)}});
  }
  reply(json_response(200, {{"job_id", job->id}, {"folder", job->folder}, {"files", files}}));
}

void get_file(const ServiceContext& context, const PathParams& params, Reply reply) {
  auto job = find_job(context, params, reply);
  if (!job) return;
  const fs::path relative = params.count("dir") ? fs::path(params.at("dir")) / params.at("name")
                                                : fs::path(params.at("name"));
  const auto missing = [&] {
    return error_response("not_found", "job " + std::to_string(job->id) + " has no file '" +
                                           clip(relative.string()) + "' (GET /v1/jobs/" +
                                           std::to_string(job->id) + "/files lists them)");
  };
  bool plain = !job->folder.empty() && relative.is_relative() && !relative.empty();
  for (const auto& part : relative) plain = plain && part != ".." && part != "." && !part.empty();
  if (!plain ||
      !within_data_dir(context.data_dir, (fs::path(job->folder) / relative).parent_path()))
    return reply(missing());
  ApiResponse response;
  if (!read_bytes(context.data_dir / job->folder / relative, &response.body))
    return reply(missing());
  response.content_type = content_type_of(relative);
  response.headers.emplace_back("Content-Disposition",
                                "attachment; filename=\"" + relative.filename().string() + "\"");
  reply(std::move(response));
}

}  // namespace

void add_job_file_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/jobs/{id}/files",
              "Every file the job wrote (frames, sidecars, manifest, model, report, plots): path "
              "in its folder, bytes, URL",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                list_files(context, params, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs/{id}/files/{name}", "One file of the job, byte for byte",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                get_file(context, params, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs/{id}/files/{dir}/{name}",
              "One file in a subfolder of the job's (plots/), byte for byte",
              [context](const ApiRequest&, const PathParams& params, Reply reply) {
                get_file(context, params, std::move(reply));
              }});
}

}  // namespace camlab::service
