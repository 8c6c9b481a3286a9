#include "test_components.hpp"

#include <chrono>
#include <thread>

#include "draco/graph/component.hpp"

namespace draco::graph::test {

Probe& GetProbe() {
  static Probe probe;
  return probe;
}

namespace {

// Source of ints (a type other than double, for type-mismatch checks), one every 10 ms of
// mission time; it knows its end (SourceEndTime).
class IntSource final : public Component {
 public:
  void Declare(Spec& spec) override {
    spec.Source();
    out_ = spec.Output<int>("out");
    spec.Param("count", &count_, {.doc = "values", .min = 0});
  }
  std::optional<Time> NextSourceTime() override {
    if (i_ >= count_) return std::nullopt;
    return Time::FromSeconds(0.01 * i_);
  }
  // Known beforehand, as a recording's length is.
  std::optional<Time> SourceEndTime() const override {
    if (count_ == 0) return std::nullopt;
    return Time::FromSeconds(0.01 * (count_ - 1));
  }
  Status Process(Context&) override {
    out_.Publish(i_++);
    return Status::Ok();
  }

 private:
  int count_ = 3;
  int i_ = 0;
  Out<int> out_;
};
DRACO_REGISTER_COMPONENT(IntSource, "test.IntSource")

// Passes doubles through; one input may be declared delayed (feedback edges).
class Relay final : public Component {
 public:
  void Declare(Spec& spec) override {
    in_ = spec.Input<double>("in");
    feedback_ = spec.Input<double>("feedback", {.required = false, .delayed = true});
    loop_ = spec.Input<double>("loop", {.required = false});
    out_ = spec.Output<double>("out");
  }
  Status Process(Context&) override {
    for (auto& m : in_.TakeAll()) out_.PublishAt(m.stamp, *m);
    feedback_.TakeAll();
    loop_.TakeAll();
    return Status::Ok();
  }

 private:
  In<double> in_;
  In<double> feedback_;
  In<double> loop_;
  Out<double> out_;
};
DRACO_REGISTER_COMPONENT(Relay, "test.Relay")

// Slow consumer that records concurrency, counts calls, sleeps per message, and can request
// a stop of the run after N messages.
class Slow final : public Component {
 public:
  void Declare(Spec& spec) override {
    spec.Param("sleep_ms", &sleep_ms_, {.unit = "ms", .min = 0});
    spec.Param("stop_after", &stop_after_, {.doc = "set the stop flag after N messages"});
    // One input per drop policy; a test connects the one it exercises.
    oldest_ = spec.Input<double>("oldest", {.depth = 2, .required = false});
    newest_ = spec.Input<double>("newest",
                                 {.depth = 2, .drop = DropPolicy::kDropNewest, .required = false});
    block_ = spec.Input<double>(
        "block",
        {.depth = 2, .drop = DropPolicy::kBlock, .required = false, .block_timeout_s = 30});
    out_ = spec.Output<double>("out");
  }
  Status Process(Context&) override {
    Probe& p = GetProbe();
    const int now = ++p.concurrent;
    int prev = p.max_concurrent.load();
    while (now > prev && !p.max_concurrent.compare_exchange_weak(prev, now)) {
    }
    for (In<double>* in : {&oldest_, &newest_, &block_}) {
      while (auto m = in->Take()) {
        std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int>(sleep_ms_ * 1000)));
        const int n = ++p.processed;
        if (stop_after_ > 0 && n >= stop_after_) p.stop_flag = true;
        out_.PublishAt(m->stamp, **m);
      }
    }
    --p.concurrent;
    return Status::Ok();
  }
  Status Stop(Context&) override {
    ++GetProbe().stops;
    return Status::Ok();
  }

 private:
  double sleep_ms_ = 0.0;
  int stop_after_ = 0;
  In<double> oldest_;
  In<double> newest_;
  In<double> block_;
  Out<double> out_;
};
DRACO_REGISTER_COMPONENT(Slow, "test.Slow")

// Fails fatally on the N-th message.
class Fatal final : public Component {
 public:
  void Declare(Spec& spec) override {
    in_ = spec.Input<double>("in");
    spec.Param("fail_at", &fail_at_, {.min = 1});
  }
  Status Process(Context&) override {
    while (in_.Take()) {
      if (++seen_ == fail_at_) return Status::Fatal("message " + std::to_string(seen_) + " is bad");
    }
    return Status::Ok();
  }

 private:
  int fail_at_ = 3;
  int seen_ = 0;
  In<double> in_;
};
DRACO_REGISTER_COMPONENT(Fatal, "test.Fatal")

}  // namespace
}  // namespace draco::graph::test
