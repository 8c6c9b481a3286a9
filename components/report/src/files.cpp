#include "draco/report/files.hpp"

#include "draco/graph/executor.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace draco::report {

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  graph::WriteFileAtomicallyOrThrow(path, bytes);
}

std::vector<Xy> ReadPlyXy(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open PLY");
  std::string line;
  if (!std::getline(f, line) || line.rfind("ply", 0) != 0) {
    throw std::runtime_error(path + ": not a PLY file");
  }
  long vertices = -1;
  int line_no = 1;
  bool ascii = false;
  int properties = 0;
  bool in_vertex = false;
  while (std::getline(f, line)) {
    ++line_no;
    std::istringstream is(line);
    std::string word;
    is >> word;
    if (word == "format") {
      std::string kind;
      is >> kind;
      ascii = kind == "ascii";
    } else if (word == "element") {
      std::string name;
      is >> name;
      in_vertex = name == "vertex";
      if (in_vertex) is >> vertices;
    } else if (word == "property" && in_vertex) {
      ++properties;
    } else if (word == "end_header") {
      break;
    }
  }
  if (!ascii) throw std::runtime_error(path + ": only ASCII PLY is read");
  if (vertices < 0 || properties < 2) throw std::runtime_error(path + ": no vertex x, y");
  std::vector<Xy> out;
  out.reserve(static_cast<std::size_t>(vertices));
  for (long i = 0; i < vertices; ++i) {
    if (!std::getline(f, line)) throw std::runtime_error(path + ": truncated vertex list");
    ++line_no;
    std::istringstream is(line);
    Xy p;
    if (!(is >> p.x >> p.y)) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": bad vertex");
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace draco::report
