// The registered component types described as text (graph.hpp DescribeRegistry): inputs,
// outputs, timers and parameters with their types, defaults, ranges and documentation.
#include <sstream>
#include <string>

#include "draco/graph/graph.hpp"
#include "graph_loader.hpp"

namespace draco::graph {

using detail::Loader;

std::string DescribeRegistry() {
  std::ostringstream os;
  for (const auto& type : Registry::Global().Types()) {
    auto node = MakeNode(type, type);
    os << type << (node->is_source ? "  [source]" : "") << "\n";
    if (!node->doc.empty()) os << "  " << node->doc << "\n";
    for (const auto& in : node->inputs) {
      const auto& o = in->options();
      os << "  input  " << in->name() << " : " << in->type_name() << "  ("
         << (o.trigger ? "triggers" : "no trigger") << ", "
         << (o.delivery == Delivery::kLatest ? "latest value" : "queue " + std::to_string(o.depth))
         << (o.required ? "" : ", optional") << (o.delayed ? ", delayed" : "") << ")";
      if (!o.doc.empty()) os << "  " << o.doc;
      os << "\n";
    }
    for (const auto& out : node->outputs) {
      os << "  output " << out->name() << " : " << out->type_name();
      if (!out->doc().empty()) os << "  " << out->doc();
      os << "\n";
    }
    for (const auto& t : node->timers) {
      os << "  timer  " << t.name << " every " << t.period.Seconds() << " s";
      if (!t.doc.empty()) os << "  " << t.doc;
      os << "\n";
    }
    for (const auto& p : node->params) {
      os << "  param  " << p.name << " : " << ParamTypeName(p.type) << " = " << p.default_text;
      if (!p.info.unit.empty()) os << " [" << p.info.unit << "]";
      if (p.info.min || p.info.max) {
        os << " range " << (p.info.min ? Loader::FormatNumber(*p.info.min) : "-inf") << ".."
           << (p.info.max ? Loader::FormatNumber(*p.info.max) : "inf");
      }
      if (!p.info.choices.empty()) {
        os << " one of";
        for (const auto& c : p.info.choices) os << " " << c;
      }
      if (!p.info.doc.empty()) os << "  " << p.info.doc;
      if (!p.info.origin.empty()) os << " (default " << p.info.origin << ")";
      os << "\n";
    }
    os << "\n";
  }
  return os.str();
}

}  // namespace draco::graph
