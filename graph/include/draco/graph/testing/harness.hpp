// Runs one component alone: build it from its type name and inline YAML parameters, feed
// timed inputs, run until idle, read what came out of each output. No threads, no DDS, no
// global state beyond the component registry.
//
//   draco::graph::testing::Harness h("example.Scale", "factor: 2.0");
//   h.Feed("in", Seconds(0.1), 21.0);
//   h.RunUntilIdle();
//   EXPECT_EQ(*h.Outputs<double>("out").at(0), 42.0);
#pragma once

#include <memory>
#include <string>
#include <typeinfo>
#include <vector>

#include "draco/graph/executor.hpp"

namespace draco::graph::testing {

class Harness {
 public:
  // Throws GraphError on an unknown type, parameter or bad value, and std::runtime_error
  // when the component's Start() fails.
  Harness(const std::string& type, const std::string& params_yaml = "",
          const RunOptions& options = {});
  ~Harness();
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  template <class T>
  void Feed(const std::string& input, Time stamp, T value) {
    FeedErased(input, stamp, std::make_shared<const T>(std::move(value)), typeid(T));
  }
  template <class T>
  void Feed(const std::string& input, Time stamp, std::shared_ptr<const T> value) {
    FeedErased(input, stamp, std::move(value), typeid(T));
  }

  // Processes everything fed so far (and, for sources, everything they emit), firing timers
  // up to the last event.
  void RunUntilIdle();
  // Same, and fires timers up to `t`.
  void RunUntil(Time t);
  // Calls the component's Stop(); what it publishes is captured too.
  void Stop();

  template <class T>
  std::vector<Stamped<T>> Outputs(const std::string& output) const {
    std::vector<Stamped<T>> out;
    for (const Envelope& e : Captured(output, typeid(T))) {
      out.push_back(
          Stamped<T>{e.stamp, std::static_pointer_cast<const T>(e.payload), e.producer_id});
    }
    return out;
  }

  Node& node();
  // The first fatal error ("" when none).
  std::string error() const;
  RunStats stats() const;

 private:
  void FeedErased(const std::string& input, Time stamp, std::shared_ptr<const void> payload,
                  const std::type_info& type);
  const std::vector<Envelope>& Captured(const std::string& output,
                                        const std::type_info& type) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace draco::graph::testing
