#pragma once
// Numeric CSV tables as the project's data files are written: any number of
// '#' comment lines, one header row of column names, then rows of numbers.
// Every malformed input raises DataError naming the source, line and what was
// wrong; nothing is guessed.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace chromo::spectral {

class DataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Table {
  std::string source;                      // file path or embedded name, for messages
  std::vector<std::string> column_names;   // from the header row
  std::vector<std::vector<double>> columns;  // columns[c][row]

  std::size_t rows() const { return columns.empty() ? 0 : columns.front().size(); }
  // Index of the named column; DataError listing the available ones if absent.
  std::size_t column_index(std::string_view name) const;
  const std::vector<double>& column(std::string_view name) const { return columns[column_index(name)]; }
};

Table parse_table(std::string_view text, const std::string& source);
// A file through files::read_text_file: a regular file of at most 16 MiB
// (files::kMaxTextFileBytes); anything else is a DataError naming the path.
Table read_table(const std::filesystem::path& path);

}  // namespace chromo::spectral
