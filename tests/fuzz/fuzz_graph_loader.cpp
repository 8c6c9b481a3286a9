// libFuzzer target: graph files as a user writes them, with every registered component.
//
// The input is text cut at lines "%%" into up to three sections:
//   1. the graph, loaded by graph::LoadGraphString with includes resolved in a scratch folder
//      that holds copies of config/graphs/*.yaml and tests/graph/data/*.yaml (so
//      `include: local-slam.yaml` reads the real files);
//   2. (optional) the text of "fuzz-include.yaml" in that folder, which the graph may include
//      (and which may include itself, or the real graphs);
//   3. (optional) command-line overrides, one "component_id.param=value" per line (--set).
// A graph that loads is rendered (ToDot) and ordered (TopologicalOrder). Every component
// library is linked (draco_link_all_components), as in apps/draco.
// Seeds: tests/fuzz/corpus/fuzz_graph_loader/ (the repository's graphs, with overrides).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "allocation_bound.hpp"
#include "draco/graph/graph.hpp"
#include "draco/log/log.hpp"

namespace {

namespace fs = std::filesystem;

fs::path g_dir;  // scratch folder for includes

std::vector<std::string> Sections(std::string_view text) {
  std::vector<std::string> out(1);
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    if (line == "%%" && out.size() < 3) {
      out.emplace_back();
    } else {
      out.back().append(line);
      if (end < text.size()) out.back() += '\n';
    }
    start = end + 1;
  }
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  draco::log::SetLevel(draco::log::Level::kOff);
  char pattern[] = "/tmp/draco-fuzz-graph-XXXXXX";
  if (::mkdtemp(pattern) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_dir = pattern;
  for (const char* folder : {"config/graphs", "tests/graph/data"}) {
    for (const auto& entry : fs::directory_iterator(fs::path(DRACO_SOURCE_DIR) / folder)) {
      if (entry.path().extension() == ".yaml") {
        fs::copy_file(entry.path(), g_dir / entry.path().filename(),
                      fs::copy_options::overwrite_existing);
      }
    }
  }
  std::atexit([] {
    std::error_code ignored;
    fs::remove_all(g_dir, ignored);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Memory bound: yaml-cpp's nodes take about 200 bytes per input byte ("[1,1,1...]"); the
  // components a graph makes are a fixed cost.
  const draco::fuzz::AllocationBound bound(size, 512, 16 << 20, "fuzz_graph_loader");
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::vector<std::string> sections = Sections(text);
  const fs::path include = g_dir / "fuzz-include.yaml";
  if (sections.size() >= 2) {
    std::ofstream(include, std::ios::binary) << sections[1];
  } else {
    std::error_code ignored;
    fs::remove(include, ignored);
  }
  draco::graph::LoadOptions options;
  if (sections.size() >= 3) {
    std::size_t start = 0;
    const std::string& set = sections[2];
    while (start < set.size()) {
      std::size_t end = set.find('\n', start);
      if (end == std::string::npos) end = set.size();
      options.overrides.push_back(set.substr(start, end - start));
      start = end + 1;
    }
  }
  try {
    auto graph = draco::graph::LoadGraphString(sections[0], "fuzz.yaml", options, g_dir.string());
    (void)draco::graph::ToDot(*graph);
    (void)graph->TopologicalOrder();
  } catch (const draco::graph::GraphError&) {
    // The expected outcome for nearly every input: diagnostics naming file and line.
  }
  return 0;
}
