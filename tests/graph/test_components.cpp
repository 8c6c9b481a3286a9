#include "test_components.hpp"

#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <thread>
#include <tuple>

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

// A robot of a pretend team: publishes a state every `period_s` of mission time that mixes
// the values its `input` brought and what the other members posted to it on a process-wide
// mailbox (outside the graph's ports) at least `delay_s` earlier; then posts the state to
// every other member, due delay_s later. Mailbox reads take only what is due, in (due,
// sender, seq) order, as the fleet link's inbox does, so the outputs depend on what the others
// did, never on how the threads ran. `work` spins that many iterations per step (uneven load).
struct Mail {
  double value;
};
std::mutex g_mail_mutex;
std::map<std::string, std::map<std::tuple<double, int, int>, Mail>> g_mail;  // to -> letters

class MailRobot final : public Component {
 public:
  void Declare(Spec& spec) override {
    in_ = spec.Input<double>("in", {.trigger = false, .depth = 4096, .required = false});
    out_ = spec.Output<double>("state");
    spec.Timer("tick", 0.5, "exchange and publish");
    spec.Param("bus", &bus_, {.doc = "mailbox name prefix"});
    spec.Param("me", &me_, {.doc = "member index", .min = 0});
    spec.Param("members", &members_, {.doc = "team size", .min = 1});
    spec.Param("delay_s", &delay_s_, {.doc = "least delay of a letter", .min = 0.0});
    spec.Param("work", &work_, {.doc = "spin iterations per step", .min = 0});
  }
  std::optional<Time> CrossIslandDelay() const override { return Time::FromSeconds(delay_s_); }
  Status Process(Context& ctx) override {
    const double now_s = ctx.Now().Seconds();
    for (const auto& m : in_.TakeAll()) state_ = std::fmod(state_ * 1.000001 + *m, 1e9);
    {
      std::lock_guard lock(g_mail_mutex);
      auto& box = g_mail[bus_ + std::to_string(me_)];
      for (auto it = box.begin(); it != box.end() && std::get<0>(it->first) <= now_s;) {
        state_ = std::fmod(state_ * 31.0 + it->second.value + std::get<1>(it->first), 1e9);
        it = box.erase(it);
      }
    }
    volatile double spin = 0.0;  // uneven load: members take turns being slow
    const int n = (static_cast<int>(now_s * 2.0) % members_ == me_) ? work_ : work_ / 10;
    for (int i = 0; i < n; ++i) spin = spin + std::sqrt(double(i));
    out_.Publish(state_);
    std::lock_guard lock(g_mail_mutex);
    for (int to = 0; to < members_; ++to) {
      if (to == me_) continue;
      g_mail[bus_ + std::to_string(to)][{now_s + delay_s_, me_, seq_}] = Mail{state_};
    }
    ++seq_;
    return Status::Ok();
  }

 private:
  std::string bus_ = "mail";
  int me_ = 0;
  int members_ = 1;
  double delay_s_ = 0.25;
  int work_ = 0;
  int seq_ = 0;
  double state_ = 1.0;
  In<double> in_;
  Out<double> out_;
};
DRACO_REGISTER_COMPONENT(MailRobot, "test.MailRobot")

// Passes doubles on stamped lag_s before they arrived (a component that publishes late).
class Lagger final : public Component {
 public:
  void Declare(Spec& spec) override {
    in_ = spec.Input<double>("in");
    out_ = spec.Output<double>("out");
    spec.Param("lag_s", &lag_s_, {.doc = "how much earlier", .min = 0.0});
  }
  Status Process(Context& ctx) override {
    for (auto& m : in_.TakeAll()) out_.PublishAt(ctx.Now() - Time::FromSeconds(lag_s_), *m);
    return Status::Ok();
  }

 private:
  double lag_s_ = 0.5;
  In<double> in_;
  Out<double> out_;
};
DRACO_REGISTER_COMPONENT(Lagger, "test.Lagger")

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
