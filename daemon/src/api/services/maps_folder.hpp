#pragma once
// The folder a MapsService call works in (maps_service.cpp): the session's
// (<sessions_dir>/<session_id>) or, without a session, the configured
// maps_dir. Inputs are relative paths that stay inside it once symbolic links
// are resolved and name regular files; outputs go to a new folder
// products/<operation>-<UTC time>-<6 hex>[-label] of their own. Nothing
// outside the folder is read, written or described. A refused request
// throws Refusal (INVALID_ARGUMENT, NOT_FOUND, ... naming the field).

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "chromo/files/decoded_exr_cache.hpp"
#include "chromo/files/float_image.hpp"
#include "services.hpp"

namespace chromo::daemon::services::maps_api {

inline constexpr std::size_t kMaxPathBytes = 4096;

// A refused request: INVALID_ARGUMENT or NOT_FOUND with the field's name.
struct Refusal {
  grpc::Status status;
};

// A library message with the command line's field names turned into the API's.
std::string api_message(const std::string& message);

class Folder {
 public:
  // The session's folder, or maps_dir for an empty session_id (Refusal: no
  // maps_dir, a bad id, no such session).
  Folder(Daemon& daemon, const std::string& session_id);

  // An input file; "" stays "" unless required. Refusal naming `field` for an
  // absolute path, "..", a link or path leading outside, a missing or
  // non-regular file.
  std::filesystem::path input(const std::string& field, const std::string& value, bool required) const;

  // The new output folder of one call (not created: the library creates it
  // and removes it again when the call fails). Refusal for a bad label or a
  // products entry that is not a folder.
  std::filesystem::path output(const std::string& operation, const std::string& label) const;

  const std::filesystem::path& base() const { return base_; }

  // A path inside the folder as the client names it.
  std::string relative(const std::filesystem::path& path) const { return path.lexically_relative(base_).string(); }
  // A library message with the folder's own path taken out.
  std::string scrub(std::string message) const;

 private:
  bool inside(const std::filesystem::path& path) const;
  std::filesystem::path base_;
  std::string what_;
};

// Illuminant and camera names that are files follow the input rule; names do not.
std::string name_or_file(const Folder& folder, const char* field, const std::string& value, const char* fallback);

// The output folder and its files, relative to the call's folder.
template <typename Response>
void add_files(const Folder& folder, const std::filesystem::path& out, const std::vector<std::filesystem::path>& files,
               Response* response) {
  response->set_out_dir(folder.relative(out));
  for (const auto& f : files) response->add_files(folder.relative(f));
}

// A scale factor field: 0 means 1; else > 0 and finite (Refusal naming it).
double scale_field(double value, const char* field);

// A maps file named by the request, decoded once while it is unchanged
// (the web view asks GetMap for each channel of one file); a file that is not
// a readable EXR is the request's fault (issue 40: INTERNAL before).
std::shared_ptr<const chromo::files::FloatImage> read_maps_file(chromo::files::DecodedExrCache& cache, const Folder& files,
                                                                 const std::string& maps_file,
                                                                 const std::string& field = "maps_file");

}  // namespace chromo::daemon::services::maps_api
