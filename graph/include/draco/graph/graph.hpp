// A graph: component instances (nodes) and the edges between their ports, loaded from a
// YAML file and validated before anything runs.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/graph/component.hpp"

namespace draco::graph {

// One problem found in a graph file: where, and what was expected.
struct Diagnostic {
  std::string file;
  int line = 0;    // 1-based, 0 when unknown
  int column = 0;  // 1-based, 0 when unknown
  std::string message;
  std::string ToString() const;  // "file:line:column: error: message"
};

// "expected one of: a, b, c (did you mean 'b'?)": the end of a diagnostic about a name that is
// not among the allowed ones (graph keys, component types, ports, parameters; apps reading
// their own YAML use it too).
std::string ExpectedOneOf(const std::vector<std::string>& allowed, const std::string& got);

// Thrown when a graph cannot be loaded; carries every problem found, not only the first.
class GraphError : public std::runtime_error {
 public:
  explicit GraphError(std::vector<Diagnostic> diagnostics);
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  std::vector<Diagnostic> diagnostics_;
};

// One component instance with the ports it declared.
class Node {
 public:
  std::uint32_t index = 0;  // position in Graph::nodes (sorted by id)
  std::string id;
  std::string type;
  std::string doc;
  std::string file;  // where it was declared
  int line = 0;
  std::unique_ptr<Component> component;
  std::vector<std::unique_ptr<InputPort>> inputs;
  std::vector<std::unique_ptr<OutputPort>> outputs;
  std::vector<TimerDecl> timers;
  std::vector<ParamDecl> params;
  bool is_source = false;

  InputPort* FindInput(const std::string& name) const;
  OutputPort* FindOutput(const std::string& name) const;
  const ParamDecl* FindParam(const std::string& name) const;
};

// Creates a component by type name and runs its Declare(). Throws std::invalid_argument
// when the type is not registered.
std::unique_ptr<Node> MakeNode(const std::string& type, const std::string& id);

struct Edge {
  std::uint32_t producer = 0;
  std::size_t output = 0;
  std::uint32_t consumer = 0;
  std::size_t input = 0;
};

struct GraphSettings {
  std::string name;
  std::string executor = "deterministic";  // or "threaded"
  double rate = 0.0;                       // 0: as fast as possible; N: N x real time
  int threads = 2;                         // threaded executor only
};

class Graph {
 public:
  GraphSettings settings;
  std::string source_file;
  std::vector<std::unique_ptr<Node>> nodes;  // sorted by id: a deterministic order
  std::vector<Edge> edges;                   // sorted by (producer, output, consumer, input)

  Node* Find(const std::string& id) const;
  // Node indices with every producer before its consumers (delayed edges ignored; ties by
  // id). Stop() is called in this order so what a component flushes reaches its consumers.
  std::vector<std::uint32_t> TopologicalOrder() const;
  // Edges leaving one output, in consumer order.
  std::vector<const Edge*> Subscribers(std::uint32_t producer, std::size_t output) const;
};

struct LoadOptions {
  // Command-line overrides "component_id.param=value" (value parsed as YAML).
  std::vector<std::string> overrides;
  // For the test harness, which feeds inputs itself.
  bool allow_unconnected_inputs = false;
};

// Loads, instantiates and validates a graph. Throws GraphError listing every problem.
std::unique_ptr<Graph> LoadGraphFile(const std::string& path, const LoadOptions& options = {});
// Same, from text; `name` stands in for the file name in diagnostics, and includes are
// resolved against `base_dir`.
std::unique_ptr<Graph> LoadGraphString(const std::string& yaml, const std::string& name,
                                       const LoadOptions& options = {},
                                       const std::string& base_dir = ".");

// Graphviz rendering: nodes with their ports, edges labelled by message type;
// delayed edges dashed.
std::string ToDot(const Graph& graph);

// The graph as loaded, as a YAML graph file: every component, its inputs (from the edges) and
// every parameter's current value, in-code defaults and overrides included. Loading it gives
// the same components, edges and parameters. Apps write it into their run folders.
std::string ResolvedYaml(const Graph& graph);

// Human-readable description of every registered component (ports, parameters, units, docs).
std::string DescribeRegistry();

}  // namespace draco::graph
