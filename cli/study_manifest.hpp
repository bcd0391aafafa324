#pragma once
// A study's manifest (docs/study.md): which session folders it holds.
//
// MANIFEST is either a file listing session folders, one per line (blank
// lines and lines starting with '#' skipped; a relative path is relative to
// the file's folder), or a glob pattern (glob(3): *, ?, [...]) matching them.
// Each session is known by its folder's name, which names its maps in the
// study (DIR/sessions/<name>/): 1-100 of [A-Za-z0-9_.+-], not "." or "..",
// unique in the study.
//
// Thread rules: free functions.

#include <filesystem>
#include <string>
#include <vector>

namespace chromo::cli::study {

struct ManifestSession {
  std::string name;
  std::filesystem::path folder;  // absolute, normalised
};

// Throws std::invalid_argument naming the manifest, the line and what is
// wrong: no such file and not a glob, a glob that matches nothing, a listed
// path that is not a directory, a name not usable as a folder, a name given
// twice (both places named), an empty manifest.
std::vector<ManifestSession> read_manifest(const std::string& manifest);

// Whether `name` can be a session's folder name in a study (see above).
bool usable_session_name(const std::string& name);

}  // namespace chromo::cli::study
