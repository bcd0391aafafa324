#pragma once
// "Did you mean ...?" for a mistyped command or option: the known word
// nearest the first word of the command line chromo did not take.
#include <string>

#include <CLI/CLI.hpp>

namespace chromo::cli {

// Levenshtein distance (insertions, deletions, substitutions), bytes.
std::size_t edit_distance(const std::string& a, const std::string& b);

// Walks argv through `app`'s subcommands and options; at the first word no
// subcommand, option or positional takes, returns "chromo: did you mean
// `chromo session list`?" (a subcommand) or "... `--subject`?" (an option of
// the command or its parents) for the nearest known word within 2 edits
// (and under half its length); "" when none is that close.
std::string typo_suggestion(const CLI::App& app, int argc, const char* const* argv);

}  // namespace chromo::cli
