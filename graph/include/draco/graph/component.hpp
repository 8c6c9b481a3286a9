// The component contract. A component is a thin adapter around an algorithm library:
// it declares its ports, timers and parameters in Declare() (before anything runs, so
// `draco validate` and `draco list` work without running it), and does its work in
// Process(). A component never runs concurrently with itself and reads time only from
// the Context (virtual in replay).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <source_location>
#include <string>
#include <typeindex>
#include <vector>

#include "draco/graph/port.hpp"
#include "draco/graph/time.hpp"
#include "draco/log/log.hpp"

namespace draco::graph {

// Readable C++ type name (demangled), used in messages and `draco list`.
std::string DemangledName(const std::type_info& type);

class Status {
 public:
  enum class Code { kOk, kError, kFatal };
  static Status Ok() { return Status(); }
  // The component could not handle this event; the run goes on (counted and logged).
  static Status Error(std::string message) { return Status(Code::kError, std::move(message)); }
  // The component cannot go on (e.g. a corrupt recording); the run stops with this error.
  static Status Fatal(std::string message) { return Status(Code::kFatal, std::move(message)); }

  bool ok() const { return code_ == Code::kOk; }
  Code code() const { return code_; }
  const std::string& message() const { return message_; }

 private:
  Status() = default;
  Status(Code code, std::string message) : code_(code), message_(std::move(message)) {}
  Code code_ = Code::kOk;
  std::string message_;
};

enum class ParamType { kBool, kInt, kDouble, kString, kDoubleList, kIntList, kStringList };
const char* ParamTypeName(ParamType type);

struct ParamInfo {
  std::string doc;                   // one line
  std::string unit;                  // "m", "s", "rad", "" when dimensionless
  std::optional<double> min;         // inclusive, numeric types and list elements
  std::optional<double> max;         // inclusive
  std::vector<std::string> choices;  // allowed values of a string parameter
  // Where the default came from when it was measured rather than chosen ("calibrated on ...",
  // with the doc section that has the figures); shown by `draco list` and --describe.
  std::string origin;
};

struct ParamDecl {
  std::string name;
  ParamType type;
  void* target;  // the component's field, typed by `type`
  ParamInfo info;
  std::string default_text;  // the in-code default, rendered as YAML
};

struct TimerDecl {
  std::string name;
  Time period;
  std::string doc;
};

class Node;

// Given to Declare(): collects the component's ports, timers and parameters.
class Spec {
 public:
  explicit Spec(Node* node) : node_(node) {}

  template <class T>
  In<T> Input(const std::string& name, InputOptions options = {}) {
    return In<T>(AddInput(name, typeid(T), DemangledName(typeid(T)), std::move(options)));
  }
  template <class T>
  Out<T> Output(const std::string& name, std::string doc = {}) {
    return Out<T>(AddOutput(name, typeid(T), DemangledName(typeid(T)), std::move(doc)));
  }
  // Process() is called with Context::timer() == name every period of mission time.
  void Timer(const std::string& name, double period_s, std::string doc = {});
  // A source produces messages on its own: the executor asks NextSourceTime() and calls
  // Process() with Context::reason() == kSource when that time comes.
  void Source(std::string doc = {});
  void Doc(std::string doc);

  void Param(const std::string& name, bool* target, ParamInfo info);
  void Param(const std::string& name, int* target, ParamInfo info);
  void Param(const std::string& name, double* target, ParamInfo info);
  void Param(const std::string& name, std::string* target, ParamInfo info);
  void Param(const std::string& name, std::vector<double>* target, ParamInfo info);
  void Param(const std::string& name, std::vector<int>* target, ParamInfo info);
  void Param(const std::string& name, std::vector<std::string>* target, ParamInfo info);

 private:
  InputPort* AddInput(const std::string& name, std::type_index type, std::string type_name,
                      InputOptions options);
  OutputPort* AddOutput(const std::string& name, std::type_index type, std::string type_name,
                        std::string doc);
  void AddParam(const std::string& name, ParamType type, void* target, ParamInfo info);
  Node* node_;
};

enum class Reason { kStart, kInput, kTimer, kSource, kStop };

class Context {
 public:
  Context(const std::string& id, const Time* now, const std::string* output_dir)
      : id_(id), now_(now), output_dir_(output_dir) {}

  Time Now() const { return *now_; }
  const std::string& id() const { return id_; }
  Reason reason() const { return reason_; }
  const std::string& timer() const { return timer_; }
  // Folder for this run's files ("" when the run writes nothing).
  const std::string& output_dir() const { return *output_dir_; }
  // True once the run was asked to stop (SIGINT/SIGTERM): a component that waits on
  // something outside the graph (a teammate, a device) should give up waiting.
  bool StopRequested() const { return stop_ != nullptr && stop_->load(); }
  void SetStopFlag(const std::atomic<bool>* stop) { stop_ = stop; }

  // Logs "[<mission time> s] <id>: message" at `level` (draco/log/log.hpp); rate-limited
  // per source line and component.
  void Log(log::Level level, const std::string& message,
           std::source_location where = std::source_location::current()) const;
  // At info level.
  void Log(const std::string& message,
           std::source_location where = std::source_location::current()) const {
    Log(log::Level::kInfo, message, where);
  }

  // Set by the executor.
  void SetEvent(Reason reason, std::string timer) {
    reason_ = reason;
    timer_ = std::move(timer);
  }

 private:
  std::string id_;
  const Time* now_;
  const std::string* output_dir_;
  const std::atomic<bool>* stop_ = nullptr;
  Reason reason_ = Reason::kStart;
  std::string timer_;
};

class Component {
 public:
  virtual ~Component() = default;
  // Declares ports, timers and parameters. Runs once, before parameters are set.
  virtual void Declare(Spec& spec) = 0;
  // Parameters are set; open files, check parameter combinations.
  virtual Status Start(Context& /*ctx*/) { return Status::Ok(); }
  // A triggering input has data, a timer fired, or (sources) the next emission is due.
  virtual Status Process(Context& ctx) = 0;
  // Sources only: mission time of the next emission; nullopt when exhausted.
  virtual std::optional<Time> NextSourceTime() { return std::nullopt; }
  // Sources only, after Start(): the stamp of the last emission when known beforehand (a
  // recording's length), for progress and ETA displays; nullopt when unknown.
  virtual std::optional<Time> SourceEndTime() const { return std::nullopt; }
  // The run ends: flush outputs (messages published here are still delivered).
  virtual Status Stop(Context& /*ctx*/) { return Status::Ok(); }
  // Parameters are set (asked before Start()): a component that exchanges data with other islands
  // of the graph outside its ports (an in-process bus between robots) returns the least mission
  // time between an event it processes and any effect of that event another island can observe.
  // With RunOptions::island_threads > 1 the deterministic executor runs islands in parallel, each
  // at most this far ahead of the others. nullopt: nothing leaves the graph but its ports.
  virtual std::optional<Time> CrossIslandDelay() const { return std::nullopt; }
};

// Type-name registry of component factories, filled by static registration.
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Component>()>;
  struct Entry {
    std::string type;
    Factory factory;
  };
  static Registry& Global();
  bool Add(const std::string& type, Factory factory);
  const Entry* Find(const std::string& type) const;
  std::vector<std::string> Types() const;  // sorted

 private:
  std::vector<Entry> entries_;
};

}  // namespace draco::graph

#define DRACO_GRAPH_CONCAT_INNER(a, b) a##b
#define DRACO_GRAPH_CONCAT(a, b) DRACO_GRAPH_CONCAT_INNER(a, b)
// Registers a component class under a type name, e.g. DRACO_REGISTER_COMPONENT(Cfar, "sonar.Cfar").
#define DRACO_REGISTER_COMPONENT(Class, type_name)                                                 \
  namespace {                                                                                      \
  const bool DRACO_GRAPH_CONCAT(draco_registered_,                                                 \
                                __LINE__) = ::draco::graph::Registry::Global().Add(type_name, [] { \
    return std::unique_ptr<::draco::graph::Component>(new Class());                                \
  });                                                                                              \
  }
