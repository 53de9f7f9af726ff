#pragma once
// The benchmarks' index and trajectory files are whitespace-separated text
// with '#' comments. This reads them into rows that remember their line number,
// so every parse error can name FILE:LINE.
#include <istream>
#include <string>
#include <vector>

namespace vslam {

struct TextRow {
  int line = 0;                     // 1-based line number in the file
  std::vector<std::string> fields;  // whitespace-separated fields
};

// Rows of a text file, skipping blank lines (whitespace as std::isspace has
// it) and lines whose first non-blank character is '#'; every row has at least
// one field. Throws InputError naming the file if it cannot be opened.
std::vector<TextRow> readTextRows(const std::string& path);
// The same from a stream; `name` is the file named in errors.
std::vector<TextRow> readTextRows(std::istream& in, const std::string& name);

// Parses a whole field as a finite number; InputError "path:line: <what> '<field>' is not a number" otherwise.
double parseNumber(const std::string& field, const std::string& path, int line, const std::string& what);

}  // namespace vslam
