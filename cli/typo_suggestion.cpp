#include "typo_suggestion.hpp"

#include <algorithm>
#include <vector>

namespace chromo::cli {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

namespace {

// The nearest of `candidates` to `word` when close enough, else "".
std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = 3;  // at most 2 edits
  for (const auto& candidate : candidates) {
    const std::size_t distance = edit_distance(word, candidate);
    if (distance < best_distance && 2 * distance < std::max(word.size(), candidate.size())) {
      best = candidate;
      best_distance = distance;
    }
  }
  return best;
}

const CLI::Option* find_option(const CLI::App* app, const std::string& name) {
  for (; app; app = app->get_parent())
    for (const CLI::Option* option : app->get_options())
      for (const auto& long_name : option->get_lnames())
        if ("--" + long_name == name) return option;
  return nullptr;
}

std::vector<std::string> option_names(const CLI::App* app) {
  std::vector<std::string> names;
  for (; app; app = app->get_parent())
    for (const CLI::Option* option : app->get_options())
      for (const auto& long_name : option->get_lnames()) names.push_back("--" + long_name);
  return names;
}

std::string command_path(const CLI::App* app) {
  std::string path;
  for (; app && app->get_parent(); app = app->get_parent()) path = app->get_name() + (path.empty() ? "" : " " + path);
  return "chromo" + (path.empty() ? "" : " " + path);
}

}  // namespace

std::string typo_suggestion(const CLI::App& app, int argc, const char* const* argv) {
  const CLI::App* current = &app;
  std::size_t positionals_taken = 0;
  for (int i = 1; i < argc; ++i) {
    std::string word = argv[i];
    if (word == "--") return "";
    if (word.rfind("--", 0) == 0) {
      const std::string name = word.substr(0, word.find('='));
      const CLI::Option* option = find_option(current, name);
      if (!option) {
        const std::string guess = nearest(name, option_names(current));
        return guess.empty() ? "" : "chromo: did you mean `" + guess + "`?";
      }
      if (word.find('=') == std::string::npos && option->get_expected_min() > 0) ++i;  // its value
      continue;
    }
    if (word.rfind('-', 0) == 0) continue;  // short options: not guessed
    std::vector<std::string> commands;
    const CLI::App* next = nullptr;
    for (const CLI::App* sub : current->get_subcommands([](const CLI::App*) { return true; })) {
      commands.push_back(sub->get_name());
      if (sub->get_name() == word) next = sub;
    }
    if (next) {
      current = next;
      positionals_taken = 0;
      continue;
    }
    std::size_t positionals = 0;
    for (const CLI::Option* option : current->get_options())
      if (option->get_positional()) ++positionals;
    if (positionals_taken < positionals) {
      ++positionals_taken;
      continue;
    }
    const std::string guess = nearest(word, commands);
    return guess.empty() ? "" : "chromo: did you mean `" + command_path(current) + " " + guess + "`?";
  }
  return "";
}

}  // namespace chromo::cli
