#pragma once
// The configuration's checks of a key's final value (config.cpp's key table
// uses them): files read as what they are, folders usable, addresses valid.
// Each returns "" when fine, else what is wrong; they only look (a missing
// folder is created and removed again to prove it can be made).

#include <filesystem>
#include <string>

namespace chromo::daemon::config_checks {

// A readable regular file.
std::string regular_file_error(const std::filesystem::path& path);
// A folder chromod may create files in: an existing writable folder, or one
// that can be created (its nearest existing ancestor is a writable folder).
std::string folder_error(const std::filesystem::path& folder);
// folder_error, and for a folder that does not exist yet, whether it can
// really be made: it is created and removed again (only what was created).
std::string folder_error_tried(const std::filesystem::path& folder);
// A Unix socket path: short enough, no other file or listener there, its folder usable ("" for "").
std::string unix_socket_error(const std::string& path);
// host:port with a numeric host (or localhost) and a port in [0, 65535]; no name lookup ("" for "").
std::string tcp_address_error(const std::string& address);
// A readable file with a -----BEGIN line ("" for "").
std::string pem_file_error(const std::string& path);
// A readable LED library file ("" for "").
std::string led_library_error(const std::string& path);
// builtin:NAME or a readable camera sensitivity CSV.
std::string camera_sensitivity_error(const std::string& source);
// estimation.films_extinction_ratio: "", "virtual_lab" or a readable extinction CSV.
std::string films_error(const std::string& source);
// "" or folder_error_tried.
std::string optional_folder(const std::string& path);
// "" or a folder that exists already (never created): the web view's files.
std::string optional_existing_folder(const std::string& path);

}  // namespace chromo::daemon::config_checks
