#pragma once
// The web view's files on disk: which file a request path names inside a
// folder (the front end's, or one session's), and serving it. Internal to
// daemon/src/api/web/. Thread rules: pure functions (serve_file reads the file).

#include <filesystem>
#include <optional>
#include <string>

#include <httplib.h>

namespace chromo::daemon::web {

// A request path's file inside `root`, or nullopt: only [A-Za-z0-9_.+:-/]
// segments (a session's derived files are named "albedo-w57+blue:8-cam0.exr"),
// none empty or starting with '.', and the resolved file must be a regular
// file under the resolved root (a symbolic link out of it is refused). "" and
// "/" name index.html.
std::optional<std::filesystem::path> static_file(const std::filesystem::path& root, std::string path);

// The file's whole content as the response body, its Content-Type from its
// extension (application/octet-stream for an unknown one).
void serve_file(const std::filesystem::path& file, httplib::Response& response);

}  // namespace chromo::daemon::web
