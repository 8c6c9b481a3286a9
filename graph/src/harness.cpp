#include "draco/graph/testing/harness.hpp"

#include <stdexcept>

#include "deterministic_engine.hpp"

namespace draco::graph::testing {

struct Harness::Impl {
  std::unique_ptr<Graph> graph;
  std::unique_ptr<internal::DeterministicEngine> engine;
  bool stopped = false;
};

namespace {
std::string Indent(const std::string& text, const std::string& prefix) {
  std::string out = prefix;
  for (char c : text) {
    out += c;
    if (c == '\n') out += prefix;
  }
  return out;
}
}  // namespace

Harness::Harness(const std::string& type, const std::string& params_yaml, const RunOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string yaml = "schema: 1\ncomponents:\n  - id: under_test\n    type: " + type + "\n";
  if (!params_yaml.empty()) yaml += "    params:\n" + Indent(params_yaml, "      ") + "\n";
  // Inputs are fed by the harness, so none has to be connected.
  LoadOptions load;
  load.allow_unconnected_inputs = true;
  impl_->graph = LoadGraphString(yaml, "<harness " + type + ">", load);
  RunOptions run = options;
  run.use_graph_rate = false;
  impl_->engine = std::make_unique<internal::DeterministicEngine>(*impl_->graph, run);
  impl_->engine->EnableTaps();
  if (!impl_->engine->StartAll()) {
    throw std::runtime_error("harness: " + type + " failed to start: " + impl_->engine->error());
  }
}

Harness::~Harness() = default;

Node& Harness::node() { return *impl_->graph->nodes.at(0); }

void Harness::FeedErased(const std::string& input, Time stamp, std::shared_ptr<const void> payload,
                         const std::type_info& type) {
  Node& n = node();
  for (std::size_t i = 0; i < n.inputs.size(); ++i) {
    if (n.inputs[i]->name() != input) continue;
    if (n.inputs[i]->type() != std::type_index(type)) {
      throw std::invalid_argument("harness: input '" + input + "' expects " +
                                  n.inputs[i]->type_name() + ", fed " + DemangledName(type));
    }
    impl_->engine->Inject(n.index, i, stamp, std::move(payload));
    return;
  }
  throw std::invalid_argument("harness: " + n.type + " has no input '" + input + "'");
}

void Harness::RunUntilIdle() { impl_->engine->RunUntil(Time::Max()); }
void Harness::RunUntil(Time t) { impl_->engine->RunUntil(t); }

void Harness::Stop() {
  if (impl_->stopped) return;
  impl_->stopped = true;
  impl_->engine->StopAll();
}

std::string Harness::error() const { return impl_->engine->error(); }

RunStats Harness::stats() const { return impl_->engine->Stats(0.0); }

const std::vector<Envelope>& Harness::Captured(const std::string& output,
                                               const std::type_info& type) const {
  const Node& n = *impl_->graph->nodes.at(0);
  for (std::size_t i = 0; i < n.outputs.size(); ++i) {
    if (n.outputs[i]->name() != output) continue;
    if (n.outputs[i]->type() != std::type_index(type)) {
      throw std::invalid_argument("harness: output '" + output + "' carries " +
                                  n.outputs[i]->type_name() + ", read as " + DemangledName(type));
    }
    return impl_->engine->Tapped(n.index, i);
  }
  throw std::invalid_argument("harness: " + n.type + " has no output '" + output + "'");
}

}  // namespace draco::graph::testing
