#pragma once
// Where chromod keeps the files of one run that are no data: its Unix socket
// and the virtual lab's camera description. One rule, shared by chromod, the
// `chromo` client and the Python client (clients/python/chromosphere_client.py
// repeats it), so that a client finds the daemon's default socket:
//
//   $CHROMO_RUNTIME_DIR, else $XDG_RUNTIME_DIR/chromosphere, else
//   $HOME/.local/state/chromosphere/run; empty when none of these is set.
//
// Never under /tmp (a folder every user can write, where a killed process
// leaves its files for anyone to find).

#include <filesystem>

namespace chromo::files {

std::filesystem::path default_runtime_dir();
// default_runtime_dir() / "chromod.sock"; empty when there is no default.
std::filesystem::path default_unix_socket();

}  // namespace chromo::files
