// Example components: a source, a transform, a two-input join, a timer and a sink.
// Each shows one part of the component contract; see docs/writing-a-component.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"

namespace draco::examples {
namespace {

using graph::Context;
using graph::InputOptions;
using graph::Spec;
using graph::Status;
using graph::Time;

// Source: emits `count` values first, first + step, ... every `period_s` of mission time.
class Ticker final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source("Emits an arithmetic sequence at a fixed mission-time period.");
    value_ = spec.Output<double>("value", "the current value of the sequence");
    spec.Param("count", &count_, {"number of values to emit", "", 0.0, 1e9, {}});
    spec.Param("period_s", &period_s_, {"time between values", "s", 1e-6, 3600.0, {}});
    spec.Param("start_s", &start_s_, {"stamp of the first value", "s", 0.0, {}, {}});
    spec.Param("first", &first_, {"first value", "", {}, {}, {}});
    spec.Param("step", &step_, {"increment between values", "", {}, {}, {}});
  }
  std::optional<Time> NextSourceTime() override {
    if (emitted_ >= count_) return std::nullopt;
    return Time::FromSeconds(start_s_ + period_s_ * emitted_);
  }
  Status Process(Context& ctx) override {
    value_.PublishAt(ctx.Now(), first_ + step_ * emitted_);
    ++emitted_;
    return Status::Ok();
  }

 private:
  int count_ = 10;
  double period_s_ = 0.1;
  double start_s_ = 0.0;
  double first_ = 0.0;
  double step_ = 1.0;
  int emitted_ = 0;
  graph::Out<double> value_;
};
DRACO_REGISTER_COMPONENT(Ticker, "example.Ticker")

// Transform: out = factor * in. Queued input, one output per input.
class Scale final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("Multiplies every value by a factor.");
    in_ = spec.Input<double>("in", {.doc = "values to scale"});
    out_ = spec.Output<double>("out", "factor x in, same stamp");
    spec.Param("factor", &factor_, {"multiplier", "", {}, {}, {}});
    spec.Param("fail_above", &fail_above_,
               {"return an error (not fatal) for inputs above this", "", {}, {}, {}});
  }
  Status Process(Context&) override {
    while (auto m = in_.Take()) {
      if (**m > fail_above_) return Status::Error("input " + std::to_string(**m) + " too large");
      out_.PublishAt(m->stamp, factor_ * **m);
    }
    return Status::Ok();
  }

 private:
  double factor_ = 1.0;
  double fail_above_ = INFINITY;
  graph::In<double> in_;
  graph::Out<double> out_;
};
DRACO_REGISTER_COMPONENT(Scale, "example.Scale")

// Join: a triggers; b is kept as its latest value and does not trigger.
class Sum final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("Adds the latest value of b to every value of a.");
    a_ = spec.Input<double>("a", {.doc = "triggers one output per value"});
    b_ = spec.Input<double>("b", {.trigger = false,
                                  .delivery = graph::Delivery::kLatest,
                                  .required = false,
                                  .doc = "latest value kept; 0 until one arrives"});
    out_ = spec.Output<double>("out", "a + latest b");
  }
  Status Process(Context&) override {
    if (auto b = b_.Take()) b_latest_ = **b;
    while (auto a = a_.Take()) out_.PublishAt(a->stamp, **a + b_latest_);
    return Status::Ok();
  }

 private:
  double b_latest_ = 0.0;
  graph::In<double> a_;
  graph::In<double> b_;
  graph::Out<double> out_;
};
DRACO_REGISTER_COMPONENT(Sum, "example.Sum")

// Timer: counts values and reports the count every period (a non-triggering input).
class RateMeter final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("Counts arrivals and publishes the count every period.");
    in_ = spec.Input<double>("in", {.trigger = false, .depth = 1024, .doc = "values to count"});
    count_ = spec.Output<double>("count", "values received in the last period");
    spec.Timer("report", 1.0, "publishes the count");
  }
  Status Process(Context&) override {
    count_.Publish(static_cast<double>(in_.TakeAll().size()));
    return Status::Ok();
  }

 private:
  graph::In<double> in_;
  graph::Out<double> count_;
};
DRACO_REGISTER_COMPONENT(RateMeter, "example.RateMeter")

// Sink: keeps every value and writes them as CSV when the run stops (flush on Stop).
class CsvSink final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc("Writes every received value to <output_dir>/<file> when the run stops.");
    in_ = spec.Input<double>("in", {.depth = 1024, .doc = "values to record"});
    spec.Param("file", &file_, {"CSV file name inside the run's output folder", "", {}, {}, {}});
  }
  Status Process(Context&) override {
    for (const auto& m : in_.TakeAll()) {
      char line[96];
      std::snprintf(line, sizeof(line), "%.9f,%s,%.17g\n", m.stamp.Seconds(),
                    m.producer ? m.producer->c_str() : "", *m);
      rows_ += line;
    }
    return Status::Ok();
  }
  Status Stop(Context& ctx) override {
    if (ctx.output_dir().empty()) return Status::Ok();
    const std::string path = (std::filesystem::path(ctx.output_dir()) / file_).string();
    if (!graph::WriteFileAtomically(path, "stamp_s,producer,value\n" + rows_)) {
      return Status::Fatal("cannot write " + path);
    }
    return Status::Ok();
  }

 private:
  std::string file_ = "values.csv";
  std::string rows_;
  graph::In<double> in_;
};
DRACO_REGISTER_COMPONENT(CsvSink, "example.CsvSink")

}  // namespace
}  // namespace draco::examples
