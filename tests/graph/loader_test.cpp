// Graph loading and validation: every error names the file, the line and what was expected.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "draco/graph/graph.hpp"

namespace draco::graph {
namespace {

// Loads text and returns the diagnostics (empty when the graph is valid).
std::vector<Diagnostic> Problems(const std::string& yaml, const LoadOptions& options = {}) {
  try {
    LoadGraphString(yaml, "g.yaml", options);
  } catch (const GraphError& e) {
    return e.diagnostics();
  }
  return {};
}

// Exactly one diagnostic, at `line`, whose message contains `text`.
void ExpectOne(const std::string& yaml, int line, const std::string& text,
               const LoadOptions& options = {}) {
  const auto d = Problems(yaml, options);
  ASSERT_EQ(d.size(), 1u) << (d.empty() ? "no error" : GraphError(d).what());
  EXPECT_EQ(d[0].file, options.overrides.empty() ? "g.yaml" : d[0].file);
  EXPECT_EQ(d[0].line, line) << d[0].ToString();
  EXPECT_NE(d[0].message.find(text), std::string::npos) << d[0].ToString();
}

const char* kValid = R"(schema: 1
name: chain
components:
  - id: src
    type: example.Ticker
    params: { count: 3, period_s: 0.5 }
  - id: scale
    type: example.Scale
    inputs: { in: src/value }
    params: { factor: 2.0 }
)";

TEST(Loader, ValidGraphIsInstantiatedSortedById) {
  auto g = LoadGraphString(kValid, "g.yaml");
  ASSERT_EQ(g->nodes.size(), 2u);
  EXPECT_EQ(g->nodes[0]->id, "scale");
  EXPECT_EQ(g->nodes[1]->id, "src");
  ASSERT_EQ(g->edges.size(), 1u);
  EXPECT_EQ(g->edges[0].producer, 1u);
  EXPECT_EQ(g->edges[0].consumer, 0u);
  EXPECT_EQ(g->settings.name, "chain");
  EXPECT_EQ(g->settings.executor, "deterministic");
}

TEST(Loader, ParametersAreApplied) {
  auto g = LoadGraphString(kValid, "g.yaml");
  const ParamDecl* factor = g->Find("scale")->FindParam("factor");
  ASSERT_NE(factor, nullptr);
  EXPECT_DOUBLE_EQ(*static_cast<double*>(factor->target), 2.0);
  EXPECT_EQ(factor->default_text, "1.0");  // the in-code default, for `draco list`
}

TEST(Loader, ResolvedYamlLoadsBackToTheSameGraph) {
  const std::string yaml = std::string(kValid) +
                           "  - id: sink\n    type: example.CsvSink\n"
                           "    inputs: { in: scale/out }\n";
  LoadOptions options;
  options.overrides = {"scale.factor=3.25", R"(sink.file='a "quoted" name.csv')"};
  auto g = LoadGraphString(yaml, "g.yaml", options);
  const std::string resolved = ResolvedYaml(*g);
  // Overrides, values from the file and in-code defaults alike.
  EXPECT_NE(resolved.find("factor: 3.25"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("count: 3"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("period_s: 0.5"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("first: "), std::string::npos) << resolved;  // not in the file
  EXPECT_NE(resolved.find("in: scale/out"), std::string::npos) << resolved;
  // fail_above defaults to infinity, which a graph file cannot say: left out, with a note
  // (and infinite again once loaded: below).
  EXPECT_NE(resolved.find("# fail_above: not finite"), std::string::npos) << resolved;
  // Loaded again: the same components, edges and parameter values.
  auto again = LoadGraphString(resolved, "resolved.yaml");
  ASSERT_EQ(again->nodes.size(), g->nodes.size());
  ASSERT_EQ(again->edges.size(), g->edges.size());
  for (std::size_t i = 0; i < g->edges.size(); ++i) {
    EXPECT_EQ(again->edges[i].producer, g->edges[i].producer);
    EXPECT_EQ(again->edges[i].consumer, g->edges[i].consumer);
  }
  const std::string twice = ResolvedYaml(*again);
  EXPECT_EQ(twice.substr(twice.find('\n')), resolved.substr(resolved.find('\n')));
  EXPECT_EQ(*static_cast<const std::string*>(again->Find("sink")->FindParam("file")->target),
            "a \"quoted\" name.csv");
  EXPECT_DOUBLE_EQ(*static_cast<const double*>(again->Find("scale")->FindParam("factor")->target),
                   3.25);
  EXPECT_TRUE(std::isinf(
      *static_cast<const double*>(again->Find("scale")->FindParam("fail_above")->target)));
}

TEST(Loader, UnknownComponentType) {
  ExpectOne("schema: 1\ncomponents:\n  - id: a\n    type: example.Scal\n", 4,
            "unknown component type 'example.Scal'; expected one of:");
  const auto d = Problems("schema: 1\ncomponents:\n  - id: a\n    type: example.Scal\n");
  EXPECT_NE(d[0].message.find("did you mean 'example.Scale'"), std::string::npos);
}

TEST(Loader, UnknownParameterNamesLineAndSuggestion) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n    params:\n"
      "      count: 3\n      perod_s: 0.2\n",
      7, "has no parameter 'perod_s'; expected one of: count, period_s");
  const auto d = Problems(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n    params:\n"
      "      perod_s: 0.2\n");
  EXPECT_EQ(d.at(0).column, 7);
  EXPECT_NE(d.at(0).message.find("did you mean 'period_s'"), std::string::npos);
}

TEST(Loader, WrongParameterType) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "    params: { count: three }\n",
      5, "parameter 'count' of 't': expected int, got 'three'");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "    params: { period_s: \"0.5\" }\n",
      5, "expected double");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "    params: { count: 2.5 }\n",
      5, "expected int, got '2.5'");
}

TEST(Loader, OutOfRangeParameter) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "    params: { period_s: -1 }\n",
      5, "value -1 is below the minimum 1e-06");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "    params: { period_s: 7200 }\n",
      5, "above the maximum 3600");
}

TEST(Loader, StringChoices) {
  // test.Slow has no choice param; use a Relay-free check through example.CsvSink strings.
  auto g = LoadGraphString(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.CsvSink\n    inputs: { in: t/value }\n    params: { file: x.csv }\n",
      "g.yaml");
  EXPECT_EQ(*static_cast<std::string*>(g->Find("s")->FindParam("file")->target), "x.csv");
}

TEST(Loader, DuplicateId) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "  - id: t\n    type: example.Ticker\n",
      5, "duplicate component id 't' (first declared at g.yaml:3)");
}

TEST(Loader, UnknownInputPort) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.Scale\n    inputs: { in: t/value, inn: t/value }\n",
      7, "has no input 'inn'; expected one of: in");
}

TEST(Loader, UnknownOutputAndProducer) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.Scale\n    inputs: { in: t/values }\n",
      7, "has no output 'values'; expected one of: value");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.Scale\n    inputs: { in: x/value }\n",
      7, "names unknown component 'x'");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.Scale\n    inputs: { in: value }\n",
      7, "expected 'producer_id/output', got 'value'");
}

TEST(Loader, TypeMismatch) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: i\n    type: test.IntSource\n  - id: s\n"
      "    type: example.Scale\n    inputs: { in: i/out }\n",
      7, "type mismatch: input 's/in' expects double but 'i/out' publishes int");
}

TEST(Loader, RequiredInputUnconnected) {
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n  - id: s\n"
      "    type: example.Scale\n",
      5, "required input 'in' of 's' (example.Scale, expects double) is not connected");
  // Optional inputs may stay unconnected.
  EXPECT_TRUE(Problems("schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
                       "  - id: s\n    type: example.Sum\n    inputs: { a: t/value }\n")
                  .empty());
}

TEST(Loader, CycleWithoutDelayedInputIsAnError) {
  const std::string head =
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n"
      "  - id: a\n    type: test.Relay\n    inputs: { in: t/value }\n"
      "  - id: b\n    type: test.Relay\n    inputs: { in: a/out, ";
  ExpectOne(head + "loop: c/out }\n  - id: c\n    type: test.Relay\n    inputs: { in: b/out }\n",
            0 + 8, "cycle b -> c -> b passes through no delayed input");
  EXPECT_TRUE(
      Problems(head +
               "feedback: c/out }\n  - id: c\n    type: test.Relay\n    inputs: { in: b/out }\n")
          .empty());
}

TEST(Loader, UnknownKeysAndSchema) {
  ExpectOne("schema: 1\nexecuter: threaded\ncomponents:\n  - id: t\n    type: example.Ticker\n", 2,
            "unknown key 'executer' in a graph");
  ExpectOne("schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n    param: {}\n", 5,
            "unknown key 'param' in a component");
  ExpectOne("schema: 2\ncomponents:\n  - id: t\n    type: example.Ticker\n", 1,
            "unsupported schema '2'; expected 1");
  ExpectOne("components:\n  - id: t\n    type: example.Ticker\n", 1, "missing 'schema: 1'");
  ExpectOne("schema: 1\nexecutor: fast\ncomponents:\n  - id: t\n    type: example.Ticker\n", 2,
            "unknown executor 'fast'");
}

TEST(Loader, YamlSyntaxErrorHasLine) {
  ExpectOne("schema: 1\ncomponents:\n  - id: t\n    type: [example.Ticker\n", 5, "YAML syntax");
}

TEST(Loader, MultipleErrorsAreAllReported) {
  const auto d = Problems(
      "schema: 1\ncomponents:\n  - id: t\n    type: example.Ticker\n    params: { cont: 1 }\n"
      "  - id: u\n    type: nope.Nope\n");
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].line, 5);
  EXPECT_EQ(d[1].line, 7);
}

TEST(Loader, Overrides) {
  LoadOptions o;
  o.overrides = {"scale.factor=3.5"};
  auto g = LoadGraphString(kValid, "g.yaml", o);
  EXPECT_DOUBLE_EQ(*static_cast<double*>(g->Find("scale")->FindParam("factor")->target), 3.5);

  o.overrides = {"scal.factor=3"};
  auto d = Problems(kValid, o);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].file, "--set");
  EXPECT_NE(d[0].message.find("no component 'scal'"), std::string::npos);
  o.overrides = {"scale.factr=3"};
  d = Problems(kValid, o);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].message.find("has no parameter 'factr'"), std::string::npos);
  o.overrides = {"scale.factor=abc"};
  d = Problems(kValid, o);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].line, 0);
  EXPECT_NE(d[0].message.find("expected double, got 'abc'"), std::string::npos);
  o.overrides = {"scale"};
  d = Problems(kValid, o);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].message.find("expected component_id.param=value"), std::string::npos);
}

TEST(Loader, IncludesResolveRelativeToTheIncludingFile) {
  const std::string dir = DRACO_GRAPH_TEST_DATA;
  auto g = LoadGraphFile(dir + "/with_include.yaml");
  ASSERT_NE(g->Find("src"), nullptr);    // from the included file
  ASSERT_NE(g->Find("scale"), nullptr);  // from the including file
  EXPECT_EQ(g->edges.size(), 1u);
}

TEST(Loader, IncludeErrorsNameTheIncludedFile) {
  const std::string dir = DRACO_GRAPH_TEST_DATA;
  try {
    LoadGraphFile(dir + "/bad_include.yaml");
    FAIL() << "expected an error";
  } catch (const GraphError& e) {
    const auto& d = e.diagnostics();
    ASSERT_EQ(d.size(), 2u) << e.what();
    EXPECT_EQ(d[0].file, dir + "/bad_include.yaml");
    EXPECT_EQ(d[0].line, 4);
    EXPECT_NE(d[0].message.find("missing.yaml' does not exist"), std::string::npos);
    EXPECT_EQ(d[1].file, dir + "/sources_bad.yaml");
    EXPECT_EQ(d[1].line, 6);
    EXPECT_NE(d[1].message.find("no parameter 'periodd_s'"), std::string::npos);
  }
}

TEST(Loader, MissingFile) {
  try {
    LoadGraphFile("/nonexistent/graph.yaml");
    FAIL();
  } catch (const GraphError& e) {
    EXPECT_NE(
        std::string(e.what()).find("/nonexistent/graph.yaml: error: graph file does not exist"),
        std::string::npos);
  }
}

// Found by fuzz_graph_loader (tests/fuzz): `include: [.]` made yaml-cpp read a directory, and
// the std::ios_base::failure it threw escaped the loader (std::terminate). A named pipe would
// have blocked the loader until someone wrote to it.
TEST(Loader, IncludeOfADirectoryOrDeviceIsAnError) {
  const std::string fifo = std::filesystem::temp_directory_path() /
                           ("draco-loader-test-" + std::to_string(::getpid()) + ".fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& target : {std::string("."), std::string("/dev/zero"), fifo}) {
    const std::string yaml = "schema: 1\ninclude: [" + target +
                             "]\ncomponents:\n  - id: src\n    type: example.Ticker\n";
    ExpectOne(yaml, 2, "is not a regular file");
  }
  std::filesystem::remove(fifo);
}

// Found by fuzz_graph_loader: a key that is a list or a mapping (`[a]: 1`) threw yaml-cpp's
// TypedBadConversion out of the loader.
TEST(Loader, KeysThatAreNotNamesAreErrors) {
  ExpectOne("schema: 1\n[a]: 1\ncomponents: []\n", 2, "expected a name as key, got a list");
  ExpectOne("schema: 1\ncomponents:\n  - id: src\n    type: example.Ticker\n    {x: 1}: 2\n", 5,
            "expected a name as key, got a mapping");
  ExpectOne(
      "schema: 1\ncomponents:\n  - id: src\n    type: example.Ticker\n"
      "    params: { [count]: 3 }\n",
      5, "expected a name as key, got a list");
  const auto d = Problems(
      "schema: 1\ncomponents:\n  - id: src\n    type: example.Ticker\n  - id: scale\n"
      "    type: example.Scale\n    inputs: { [in]: src/value }\n");
  ASSERT_FALSE(d.empty());
  EXPECT_EQ(d[0].line, 7) << d[0].ToString();
  EXPECT_NE(d[0].message.find("expected a name as key, got a list"), std::string::npos);
}

// The input fuzz_graph_loader found (tests/data/fuzz/graph-include-directory.txt), as it was.
TEST(Loader, FuzzFoundIncludeOfADirectory) {
  const std::string dir = DRACO_SOURCE_DIR "/tests/data/fuzz";
  std::ifstream in(dir + "/graph-include-directory.txt");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  try {
    LoadGraphString(text, "fuzz.yaml", {}, dir);
    FAIL() << "expected an error";
  } catch (const GraphError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("fuzz.yaml:2:11: error: included '" + dir), std::string::npos) << what;
    EXPECT_NE(what.find("is not a regular file"), std::string::npos) << what;
  }
}

TEST(Loader, GraphFileThatIsADirectoryIsAnError) {
  try {
    LoadGraphFile(DRACO_GRAPH_TEST_DATA);
    FAIL() << "expected an error";
  } catch (const GraphError& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
}

TEST(Loader, DotShowsNodesEdgesAndTypes) {
  auto g = LoadGraphString(kValid, "g.yaml");
  const std::string dot = ToDot(*g);
  EXPECT_NE(dot.find("digraph \"chain\""), std::string::npos);
  EXPECT_NE(dot.find("\"src\":out_value -> \"scale\":in_in [label=\"double\"]"), std::string::npos)
      << dot;
}

TEST(Loader, DescribeRegistryListsPortsParamsUnits) {
  const std::string text = DescribeRegistry();
  EXPECT_NE(text.find("example.Ticker  [source]"), std::string::npos);
  EXPECT_NE(text.find("param  period_s : double = 0.1 [s]"), std::string::npos) << text;
  EXPECT_NE(text.find("input  b : double  (no trigger, latest value, optional)"),
            std::string::npos);
}

}  // namespace
}  // namespace draco::graph
