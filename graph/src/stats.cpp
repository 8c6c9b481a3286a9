#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "stats_recorder.hpp"

namespace draco::graph {

std::uint64_t ComponentStats::dropped() const {
  std::uint64_t n = 0;
  for (const auto& in : inputs) n += in.dropped;
  return n;
}

namespace {

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

}  // namespace

std::string RunStats::ToTable() const {
  std::ostringstream os;
  char line[256];
  std::snprintf(line, sizeof(line), "%-24s %-28s %9s %9s %9s %9s %7s %7s\n", "component", "type",
                "calls", "mean ms", "p99 ms", "max ms", "errors", "drops");
  os << line;
  for (const auto& c : components) {
    std::snprintf(line, sizeof(line), "%-24s %-28s %9llu %9.3f %9.3f %9.3f %7llu %7llu\n",
                  c.id.c_str(), c.type.c_str(), static_cast<unsigned long long>(c.calls), c.mean_ms,
                  c.p99_ms, c.max_ms, static_cast<unsigned long long>(c.errors),
                  static_cast<unsigned long long>(c.dropped()));
    os << line;
  }
  std::snprintf(line, sizeof(line), "executor %s: %.3f s wall, %.3f s mission time\n",
                executor.c_str(), wall_s, mission_s);
  os << line;
  return os.str();
}

std::string RunStats::ToJson() const {
  std::ostringstream os;
  os << "{\n  \"executor\": " << JsonString(executor) << ",\n  \"wall_s\": " << Num(wall_s)
     << ",\n  \"mission_s\": " << Num(mission_s) << ",\n  \"components\": [";
  for (std::size_t i = 0; i < components.size(); ++i) {
    const auto& c = components[i];
    os << (i ? "," : "") << "\n    {\"id\": " << JsonString(c.id)
       << ", \"type\": " << JsonString(c.type) << ", \"calls\": " << c.calls
       << ", \"errors\": " << c.errors << ", \"mean_ms\": " << Num(c.mean_ms)
       << ", \"p99_ms\": " << Num(c.p99_ms) << ", \"max_ms\": " << Num(c.max_ms)
       << ", \"total_ms\": " << Num(c.total_ms) << ", \"inputs\": [";
    for (std::size_t j = 0; j < c.inputs.size(); ++j) {
      os << (j ? ", " : "") << "{\"name\": " << JsonString(c.inputs[j].name)
         << ", \"received\": " << c.inputs[j].received << ", \"dropped\": " << c.inputs[j].dropped
         << "}";
    }
    os << "]}";
  }
  os << "\n  ]\n}\n";
  return os.str();
}

void WriteFileAtomicallyOrThrow(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".partial." + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error(path + ": cannot write (" + tmp + ")");
    f.write(text.data(), static_cast<std::streamsize>(text.size()));
    f.flush();
    if (!f) {
      f.close();
      std::remove(tmp.c_str());
      throw std::runtime_error(path + ": write failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot rename into place: " + ec.message());
  }
}

bool WriteFileAtomically(const std::string& path, const std::string& text) {
  try {
    WriteFileAtomicallyOrThrow(path, text);
    return true;
  } catch (const std::runtime_error&) {
    return false;
  }
}

Time ExpectedEnd(const Graph& graph, const RunOptions& options) {
  std::optional<Time> sources_end;
  bool all_known = true;
  for (const auto& n : graph.nodes) {
    if (!n->is_source) continue;
    std::optional<Time> end;
    try {
      end = n->component->SourceEndTime();
    } catch (const std::exception&) {
      end.reset();
    }
    if (!end) {
      all_known = false;
      continue;
    }
    sources_end = sources_end ? std::max(*sources_end, *end) : *end;
  }
  if (all_known && sources_end) return std::min(options.until, *sources_end);
  return options.until;
}

namespace internal {

std::string InvokeComponent(Node& node, Context& ctx, Reason reason, StatsRecorder& recorder,
                            bool log_errors) {
  Status status = Status::Ok();
  const auto t0 = std::chrono::steady_clock::now();
  try {
    switch (reason) {
      case Reason::kStart:
        status = node.component->Start(ctx);
        break;
      case Reason::kStop:
        status = node.component->Stop(ctx);
        break;
      default:
        status = node.component->Process(ctx);
        break;
    }
  } catch (const std::exception& e) {
    status = Status::Error(std::string("exception: ") + e.what());
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (reason != Reason::kStart && reason != Reason::kStop) recorder.Record(node.index, ms);
  if (status.code() == Status::Code::kFatal || (!status.ok() && reason == Reason::kStart)) {
    return node.id + ": " + status.message();
  }
  if (!status.ok()) {
    recorder.RecordError(node.index);
    // Rate-limited per component by the logger: a flood of errors is counted and summarised.
    if (log_errors) ctx.Log(log::Level::kError, "error: " + status.message());
  }
  return "";
}

RunStats StatsRecorder::Collect(const Graph& graph, const std::string& executor, double wall_s,
                                Time mission_end) const {
  RunStats stats;
  stats.executor = executor;
  stats.wall_s = wall_s;
  stats.mission_s = mission_end.Seconds();
  for (const auto& n : graph.nodes) {
    const PerNode& p = per_node_[n->index];
    ComponentStats c;
    c.id = n->id;
    c.type = n->type;
    c.calls = p.calls;
    c.errors = p.errors;
    c.total_ms = p.total_ms;
    c.max_ms = p.max_ms;
    c.mean_ms = p.calls > 0 ? p.total_ms / static_cast<double>(p.calls) : 0.0;
    if (!p.samples.empty()) {
      std::vector<float> s = p.samples;
      const std::size_t k = std::min(s.size() - 1, (s.size() * 99) / 100);
      std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
      c.p99_ms = s[k];
    }
    for (const auto& in : n->inputs) {
      c.inputs.push_back(InputStats{in->name(), in->received(), in->dropped()});
    }
    stats.components.push_back(std::move(c));
  }
  return stats;
}

}  // namespace internal
}  // namespace draco::graph
