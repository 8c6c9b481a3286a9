// A small CSV reader shared by the report's evaluations (internal: not installed).
#pragma once

#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace draco::report::internal {

inline std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream is(line);
  while (std::getline(is, cell, ',')) {
    while (!cell.empty() && (cell.back() == '\r' || cell.back() == ' ')) cell.pop_back();
    out.push_back(cell);
  }
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

inline bool Blank(const std::string& line) {
  return line.find_first_not_of(" \t\r") == std::string::npos;
}

// A CSV with a header: rows as cells, columns looked up by name.
struct Csv {
  std::string path;
  std::map<std::string, std::size_t> column;
  std::vector<std::vector<std::string>> rows;
  std::vector<int> line_numbers;

  std::size_t Col(const std::string& name) const {
    const auto it = column.find(name);
    if (it == column.end()) throw std::runtime_error(path + ": no column '" + name + "'");
    return it->second;
  }
  double Number(std::size_t row, std::size_t col) const {
    const auto& cells = rows[row];
    if (col >= cells.size()) {
      throw std::runtime_error(path + ":" + std::to_string(line_numbers[row]) +
                               ": too few columns");
    }
    try {
      std::size_t used = 0;
      const double v = std::stod(cells[col], &used);
      if (used != cells[col].size()) throw std::invalid_argument("trailing characters");
      return v;
    } catch (const std::exception&) {
      throw std::runtime_error(path + ":" + std::to_string(line_numbers[row]) + ": '" + cells[col] +
                               "' is not a number");
    }
  }
};

inline Csv ReadCsv(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open");
  Csv csv;
  csv.path = path;
  std::string line;
  int n = 0;
  bool header = true;
  while (std::getline(f, line)) {
    ++n;
    if (Blank(line)) continue;
    auto cells = SplitCsv(line);
    if (header) {
      for (std::size_t i = 0; i < cells.size(); ++i) csv.column[cells[i]] = i;
      header = false;
      continue;
    }
    csv.rows.push_back(std::move(cells));
    csv.line_numbers.push_back(n);
  }
  return csv;
}

}  // namespace draco::report::internal
