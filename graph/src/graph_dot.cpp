// A graph in Graphviz dot (graph.hpp ToDot): nodes as records with their ports, edges labelled
// with the message type, delayed inputs dashed, non-triggering ones with an empty arrowhead.
#include <sstream>
#include <string>

#include "draco/graph/graph.hpp"

namespace draco::graph {

namespace {
std::string DotEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\' || c == '<' || c == '>' || c == '{' || c == '}' || c == '|') {
      out += '\\';
    }
    out += c;
  }
  return out;
}
}  // namespace

std::string ToDot(const Graph& graph) {
  std::ostringstream os;
  os << "digraph \"" << DotEscape(graph.settings.name) << "\" {\n"
     << "  rankdir=LR;\n  node [shape=record, fontname=\"Helvetica\", fontsize=10];\n"
     << "  edge [fontname=\"Helvetica\", fontsize=8];\n";
  for (const auto& n : graph.nodes) {
    os << "  \"" << DotEscape(n->id) << "\" [label=\"{";
    std::string ins;
    for (const auto& p : n->inputs) {
      ins += (ins.empty() ? "" : "|") + ("<in_" + p->name() + "> " + DotEscape(p->name()));
    }
    std::string outs;
    for (const auto& p : n->outputs) {
      outs += (outs.empty() ? "" : "|") + ("<out_" + p->name() + "> " + DotEscape(p->name()));
    }
    if (!ins.empty()) os << "{" << ins << "}|";
    os << DotEscape(n->id) << "\\n" << DotEscape(n->type);
    if (!outs.empty()) os << "|{" << outs << "}";
    os << "}\"];\n";
  }
  for (const auto& e : graph.edges) {
    const Node& p = *graph.nodes[e.producer];
    const Node& c = *graph.nodes[e.consumer];
    const OutputPort& out = *p.outputs[e.output];
    const InputPort& in = *c.inputs[e.input];
    std::string type = out.type_name();
    if (auto pos = type.rfind("::"); pos != std::string::npos) type = type.substr(pos + 2);
    os << "  \"" << DotEscape(p.id) << "\":out_" << out.name() << " -> \"" << DotEscape(c.id)
       << "\":in_" << in.name() << " [label=\"" << DotEscape(type) << "\"";
    if (in.options().delayed) os << ", style=dashed";
    if (!in.options().trigger) os << ", arrowhead=empty";
    os << "];\n";
  }
  os << "}\n";
  return os.str();
}

}  // namespace draco::graph
