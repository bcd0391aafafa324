#include "chromo/spectral/table.hpp"

#include <charconv>
#include <cmath>

#include "chromo/files/bounded_read.hpp"

namespace chromo::spectral {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

}  // namespace

std::size_t Table::column_index(std::string_view name) const {
  for (std::size_t i = 0; i < column_names.size(); ++i)
    if (column_names[i] == name) return i;
  std::string available;
  for (const auto& n : column_names) available += (available.empty() ? "" : ", ") + n;
  throw DataError(source + ": no column '" + std::string(name) + "' (columns: " + available + ")");
}

Table parse_table(std::string_view text, const std::string& source) {
  Table table;
  table.source = source;
  std::size_t line_number = 0;
  std::size_t position = 0;
  bool have_header = false;
  while (position < text.size()) {
    std::size_t end = text.find('\n', position);
    std::string_view line = text.substr(position, end == std::string_view::npos ? std::string_view::npos : end - position);
    position = end == std::string_view::npos ? text.size() : end + 1;
    ++line_number;
    line = trim(line);
    if (line.empty() || line.front() == '#') continue;
    auto fields = split_fields(line);
    const std::string where = source + ":" + std::to_string(line_number) + ": ";
    if (!have_header) {
      for (auto f : fields) {
        if (f.empty()) throw DataError(where + "empty column name in header");
        table.column_names.emplace_back(f);
      }
      if (table.column_names.size() < 2) throw DataError(where + "header needs at least two columns");
      table.columns.resize(table.column_names.size());
      have_header = true;
      continue;
    }
    if (fields.size() != table.column_names.size()) {
      throw DataError(where + "expected " + std::to_string(table.column_names.size()) + " fields, found " +
                      std::to_string(fields.size()));
    }
    for (std::size_t c = 0; c < fields.size(); ++c) {
      double value = 0;
      const char* first = fields[c].data();
      const char* last = first + fields[c].size();
      auto [ptr, ec] = std::from_chars(first, last, value);
      if (ec != std::errc() || ptr != last || !std::isfinite(value)) {
        throw DataError(where + "column '" + table.column_names[c] + "': '" + std::string(fields[c]) +
                        "' is not a finite number");
      }
      table.columns[c].push_back(value);
    }
  }
  if (!have_header) throw DataError(source + ": no header row (is the file empty?)");
  if (table.rows() == 0) throw DataError(source + ": header but no data rows");
  return table;
}

Table read_table(const std::filesystem::path& path) {
  std::string text;
  try {
    text = files::read_text_file(path, "CSV");
  } catch (const files::InputFileError& e) {
    throw DataError(e.what());
  }
  return parse_table(text, path.string());
}

}  // namespace chromo::spectral
