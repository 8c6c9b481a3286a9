// The graph model (graph.hpp): diagnostics and their error, port and parameter look-up on a
// node, making a node of a registered type, the execution order. Loading is in graph_load.cpp
// (with graph_params.cpp and graph_validate.cpp), output in graph_dot.cpp and
// graph_describe.cpp.
#include "draco/graph/graph.hpp"

#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace draco::graph {

std::string Diagnostic::ToString() const {
  std::ostringstream os;
  os << file;
  if (line > 0) {
    os << ":" << line;
    if (column > 0) os << ":" << column;
  }
  os << ": error: " << message;
  return os.str();
}

namespace {
std::string JoinDiagnostics(const std::vector<Diagnostic>& diagnostics) {
  std::string out;
  for (const auto& d : diagnostics) {
    if (!out.empty()) out += "\n";
    out += d.ToString();
  }
  return out;
}
}  // namespace

GraphError::GraphError(std::vector<Diagnostic> diagnostics)
    : std::runtime_error(JoinDiagnostics(diagnostics)), diagnostics_(std::move(diagnostics)) {}

InputPort* Node::FindInput(const std::string& name) const {
  for (const auto& p : inputs) {
    if (p->name() == name) return p.get();
  }
  return nullptr;
}

OutputPort* Node::FindOutput(const std::string& name) const {
  for (const auto& p : outputs) {
    if (p->name() == name) return p.get();
  }
  return nullptr;
}

const ParamDecl* Node::FindParam(const std::string& name) const {
  for (const auto& p : params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::unique_ptr<Node> MakeNode(const std::string& type, const std::string& id) {
  const Registry::Entry* entry = Registry::Global().Find(type);
  if (entry == nullptr) throw std::invalid_argument("unknown component type '" + type + "'");
  auto node = std::make_unique<Node>();
  node->id = id;
  node->type = type;
  node->component = entry->factory();
  Spec spec(node.get());
  node->component->Declare(spec);
  return node;
}

Node* Graph::Find(const std::string& id) const {
  for (const auto& n : nodes) {
    if (n->id == id) return n.get();
  }
  return nullptr;
}

std::vector<std::uint32_t> Graph::TopologicalOrder() const {
  std::vector<int> indegree(nodes.size(), 0);
  for (const auto& e : edges) {
    if (!nodes[e.consumer]->inputs[e.input]->options().delayed) ++indegree[e.consumer];
  }
  std::vector<std::uint32_t> order;
  std::vector<bool> done(nodes.size(), false);
  while (order.size() < nodes.size()) {
    // Smallest index (= smallest id) among the ready nodes; a leftover cycle is broken by id.
    std::uint32_t pick = static_cast<std::uint32_t>(nodes.size());
    for (std::uint32_t i = 0; i < nodes.size() && pick == nodes.size(); ++i) {
      if (!done[i] && indegree[i] == 0) pick = i;
    }
    for (std::uint32_t i = 0; i < nodes.size() && pick == nodes.size(); ++i) {
      if (!done[i]) pick = i;
    }
    done[pick] = true;
    order.push_back(pick);
    for (const auto& e : edges) {
      if (e.producer == pick && !nodes[e.consumer]->inputs[e.input]->options().delayed) {
        --indegree[e.consumer];
      }
    }
  }
  return order;
}

std::vector<const Edge*> Graph::Subscribers(std::uint32_t producer, std::size_t output) const {
  std::vector<const Edge*> out;
  for (const auto& e : edges) {
    if (e.producer == producer && e.output == output) out.push_back(&e);
  }
  return out;
}

}  // namespace draco::graph
