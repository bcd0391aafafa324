#pragma once
// The one temporary-name rule of every durable write, and the cleaner of the
// temporaries a crash leaves behind.
//
// Rule: the temporary of DIR/NAME is DIR/.tmp-<pid>-<tid>-NAME, where <pid> is
// the writing process and <tid> its writing thread (Linux thread id).
//  - In the same directory, so the final rename() is atomic.
//  - A hidden name that starts with ".tmp-": a directory listing that looks
//    for a prefix or an extension never takes a temporary for a result, and a
//    name without ".tmp-" is always complete.
//  - NAME comes last, so its extension stays last (OpenCV and OpenEXR pick
//    the format by the name).
//  - <pid> and <tid> keep two writers of the same file (two processes, or two
//    threads of one process filling the same cache) off each other's bytes,
//    and let the cleaner tell a crashed writer's temporary from a live one's.
//
// Every writer in files/ (write_file_durably, commit_file_durably,
// OutputBatch, the binary caches) names its temporaries with
// temporary_path_for(); nothing else in the project makes temporary names.
//
// Thread rules: free functions, reentrant.

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

namespace chromo::files {

// The temporary of `path` for the calling process and thread.
std::filesystem::path temporary_path_for(const std::filesystem::path& path);

// The writer's process id when `file_name` (a name, not a path) follows the
// rule, std::nullopt otherwise (e.g. "profiles.f32.tmp", ".tmp-x-1-a").
std::optional<long> temporary_writer_pid(const std::string& file_name);

enum class Subfolders { kSkip, kInclude };

// Removes the temporaries of the rule in `directory` (and in its sub-folders
// with Subfolders::kInclude) that no running process other than the caller
// is writing: those of a process that no longer runs (a crash) and the
// caller's own. Call it where the calling process is not writing into
// `directory` yet (a daemon recovering its folders at start). Files that do
// not follow the rule are left alone. Returns how many it removed; a missing
// directory removes nothing; std::filesystem::filesystem_error (naming the
// file) when a leftover cannot be removed.
std::size_t remove_leftover_temporaries(const std::filesystem::path& directory,
                                        Subfolders subfolders = Subfolders::kSkip);

}  // namespace chromo::files
