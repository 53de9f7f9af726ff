#include "vslam/io/text_table.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "vslam/core/error.hpp"

namespace vslam {

std::vector<TextRow> readTextRows(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open file");
  return readTextRows(in, path);
}

std::vector<TextRow> readTextRows(std::istream& in, const std::string& path) {
  std::vector<TextRow> rows;
  std::string text;
  int line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    TextRow row;
    row.line = line_number;
    std::istringstream fields(text);
    std::string field;
    while (fields >> field) row.fields.push_back(field);
    // Blank means no field at all: a line of only form feeds or vertical tabs
    // (any std::isspace) is blank too, so every row has a first field.
    if (row.fields.empty() || row.fields[0][0] == '#') continue;
    rows.push_back(std::move(row));
  }
  if (in.bad()) throw InputError(path, line_number + 1, "read error");
  return rows;
}

double parseNumber(const std::string& field, const std::string& path, int line, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(field.c_str(), &end);
  if (field.empty() || end != field.c_str() + field.size() || errno == ERANGE || !std::isfinite(value))
    throw InputError(path, line, what + " '" + field + "' is not a number");
  return value;
}

}  // namespace vslam
