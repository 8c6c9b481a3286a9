// Connecting and checking a loaded graph: nodes in id order, the input bindings resolved to
// edges (unknown producers and outputs, type mismatches, double bindings), required inputs
// left unconnected, cycles through no delayed input.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "draco/graph/graph.hpp"
#include "graph_loader.hpp"

namespace draco::graph::detail {

void Loader::SortNodes() {
  auto& nodes = graph_->nodes;
  std::sort(nodes.begin(), nodes.end(), [](const auto& a, const auto& b) { return a->id < b->id; });
  for (std::size_t i = 0; i < nodes.size(); ++i) nodes[i]->index = static_cast<std::uint32_t>(i);
}

void Loader::ConnectInputs() {
  std::set<std::pair<std::string, std::string>> seen;
  for (const auto& pi : pending_inputs_) {
    const Node* producer = graph_->Find(pi.producer);
    Node* consumer = graph_->Find(pi.consumer);
    if (producer == nullptr) {
      std::vector<std::string> ids;
      for (auto& n : graph_->nodes) ids.push_back(n->id);
      Error(pi.file, pi.mark,
            "input '" + pi.port + "' of '" + pi.consumer + "' names unknown component '" +
                pi.producer + "'; " + Expected(ids, pi.producer));
      continue;
    }
    const OutputPort* out = producer->FindOutput(pi.output);
    if (out == nullptr) {
      std::vector<std::string> names;
      for (const auto& p : producer->outputs) names.push_back(p->name());
      Error(pi.file, pi.mark,
            "component '" + producer->id + "' (" + producer->type + ") has no output '" +
                pi.output + "'; " + Expected(names, pi.output));
      continue;
    }
    InputPort* in = consumer->FindInput(pi.port);
    if (out->type() != in->type()) {
      Error(pi.file, pi.mark,
            "type mismatch: input '" + pi.consumer + "/" + pi.port + "' expects " +
                in->type_name() + " but '" + pi.producer + "/" + pi.output + "' publishes " +
                out->type_name());
      continue;
    }
    if (!seen.insert({pi.consumer, pi.port}).second) {
      Error(pi.file, pi.mark, "input '" + pi.port + "' of '" + pi.consumer + "' bound twice");
      continue;
    }
    in->set_connected(true);
    Edge e;
    e.producer = producer->index;
    e.output = out->index();
    e.consumer = consumer->index;
    for (std::size_t i = 0; i < consumer->inputs.size(); ++i) {
      if (consumer->inputs[i].get() == in) e.input = i;
    }
    graph_->edges.push_back(e);
  }
  std::sort(graph_->edges.begin(), graph_->edges.end(), [](const Edge& a, const Edge& b) {
    return std::tie(a.producer, a.output, a.consumer, a.input) <
           std::tie(b.producer, b.output, b.consumer, b.input);
  });
}

void Loader::CheckRequiredInputs() {
  for (const auto& n : graph_->nodes) {
    for (const auto& in : n->inputs) {
      if (in->options().required && !in->connected()) {
        diagnostics_.push_back(Diagnostic{n->file, n->line, 0,
                                          "required input '" + in->name() + "' of '" + n->id +
                                              "' (" + n->type + ", expects " + in->type_name() +
                                              ") is not connected; add 'inputs: {" + in->name() +
                                              ": producer_id/output}'"});
      }
    }
  }
}

// A cycle must pass through at least one input marked delayed.
void Loader::CheckCycles() {
  const auto& nodes = graph_->nodes;
  std::vector<std::vector<std::uint32_t>> next(nodes.size());
  for (const auto& e : graph_->edges) {
    if (!nodes[e.consumer]->inputs[e.input]->options().delayed) {
      next[e.producer].push_back(e.consumer);
    }
  }
  std::vector<int> state(nodes.size(), 0);  // 0 new, 1 on stack, 2 done
  std::vector<std::uint32_t> stack;
  bool reported = false;
  std::function<void(std::uint32_t)> visit = [&](std::uint32_t v) {
    state[v] = 1;
    stack.push_back(v);
    for (std::uint32_t w : next[v]) {
      if (reported) break;
      if (state[w] == 1) {
        std::string path;
        auto it = std::find(stack.begin(), stack.end(), w);
        for (; it != stack.end(); ++it) path += nodes[*it]->id + " -> ";
        path += nodes[w]->id;
        diagnostics_.push_back(
            Diagnostic{nodes[w]->file, nodes[w]->line, 0,
                       "cycle " + path +
                           " passes through no delayed input; mark one input of the "
                           "cycle delayed (InputOptions::delayed) to break it"});
        reported = true;
      } else if (state[w] == 0) {
        visit(w);
      }
    }
    stack.pop_back();
    state[v] = 2;
  };
  for (std::uint32_t v = 0; v < nodes.size() && !reported; ++v) {
    if (state[v] == 0) visit(v);
  }
}

}  // namespace draco::graph::detail
