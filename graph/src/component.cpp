#include "draco/graph/component.hpp"

#include <cxxabi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "draco/graph/graph.hpp"

namespace draco::graph {

std::string DemangledName(const std::type_info& type) {
  int status = 0;
  char* name = abi::__cxa_demangle(type.name(), nullptr, nullptr, &status);
  std::string out = (status == 0 && name != nullptr) ? name : type.name();
  std::free(name);
  // Shorten the standard library's noise in user-facing messages.
  const std::string verbose =
      "std::__cxx11::basic_string<char, std::char_traits<char>, std::allocator<char> >";
  for (auto pos = out.find(verbose); pos != std::string::npos; pos = out.find(verbose)) {
    out.replace(pos, verbose.size(), "std::string");
  }
  return out;
}

const char* ParamTypeName(ParamType type) {
  switch (type) {
    case ParamType::kBool:
      return "bool";
    case ParamType::kInt:
      return "int";
    case ParamType::kDouble:
      return "double";
    case ParamType::kString:
      return "string";
    case ParamType::kDoubleList:
      return "list of double";
    case ParamType::kIntList:
      return "list of int";
    case ParamType::kStringList:
      return "list of string";
  }
  return "?";
}

namespace {

std::string FormatDouble(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  std::string s = os.str();
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string Quote(const std::string& s) { return "\"" + s + "\""; }

template <class T, class F>
std::string FormatList(const std::vector<T>& values, F format) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ", ";
    out += format(values[i]);
  }
  return out + "]";
}

std::string RenderDefault(ParamType type, const void* target) {
  switch (type) {
    case ParamType::kBool:
      return *static_cast<const bool*>(target) ? "true" : "false";
    case ParamType::kInt:
      return std::to_string(*static_cast<const int*>(target));
    case ParamType::kDouble:
      return FormatDouble(*static_cast<const double*>(target));
    case ParamType::kString:
      return Quote(*static_cast<const std::string*>(target));
    case ParamType::kDoubleList:
      return FormatList(*static_cast<const std::vector<double>*>(target), FormatDouble);
    case ParamType::kIntList:
      return FormatList(*static_cast<const std::vector<int>*>(target),
                        [](int v) { return std::to_string(v); });
    case ParamType::kStringList:
      return FormatList(*static_cast<const std::vector<std::string>*>(target), Quote);
  }
  return "";
}

void CheckUnique(const Node& node, const std::string& what, const std::string& name) {
  const bool taken = node.FindInput(name) != nullptr || node.FindOutput(name) != nullptr ||
                     node.FindParam(name) != nullptr;
  if (name.empty() || taken) {
    throw std::logic_error("component type '" + node.type + "' declares " + what + " '" + name +
                           "' twice or with an empty name");
  }
}

}  // namespace

InputPort* Spec::AddInput(const std::string& name, std::type_index type, std::string type_name,
                          InputOptions options) {
  CheckUnique(*node_, "input", name);
  node_->inputs.push_back(
      std::make_unique<InputPort>(name, type, std::move(type_name), std::move(options)));
  return node_->inputs.back().get();
}

OutputPort* Spec::AddOutput(const std::string& name, std::type_index type, std::string type_name,
                            std::string doc) {
  CheckUnique(*node_, "output", name);
  node_->outputs.push_back(
      std::make_unique<OutputPort>(name, type, std::move(type_name), std::move(doc)));
  node_->outputs.back()->set_index(node_->outputs.size() - 1);
  return node_->outputs.back().get();
}

void Spec::Timer(const std::string& name, double period_s, std::string doc) {
  if (!(period_s > 0.0)) {
    throw std::logic_error("component type '" + node_->type + "': timer '" + name +
                           "' needs a positive period");
  }
  node_->timers.push_back(TimerDecl{name, Time::FromSeconds(period_s), std::move(doc)});
}

void Spec::Source(std::string doc) {
  node_->is_source = true;
  if (!doc.empty()) node_->doc = std::move(doc);
}

void Spec::Doc(std::string doc) { node_->doc = std::move(doc); }

void Spec::AddParam(const std::string& name, ParamType type, void* target, ParamInfo info) {
  CheckUnique(*node_, "parameter", name);
  node_->params.push_back(
      ParamDecl{name, type, target, std::move(info), RenderDefault(type, target)});
}

void Spec::Param(const std::string& name, bool* target, ParamInfo info) {
  AddParam(name, ParamType::kBool, target, std::move(info));
}
void Spec::Param(const std::string& name, int* target, ParamInfo info) {
  AddParam(name, ParamType::kInt, target, std::move(info));
}
void Spec::Param(const std::string& name, double* target, ParamInfo info) {
  AddParam(name, ParamType::kDouble, target, std::move(info));
}
void Spec::Param(const std::string& name, std::string* target, ParamInfo info) {
  AddParam(name, ParamType::kString, target, std::move(info));
}
void Spec::Param(const std::string& name, std::vector<double>* target, ParamInfo info) {
  AddParam(name, ParamType::kDoubleList, target, std::move(info));
}
void Spec::Param(const std::string& name, std::vector<int>* target, ParamInfo info) {
  AddParam(name, ParamType::kIntList, target, std::move(info));
}
void Spec::Param(const std::string& name, std::vector<std::string>* target, ParamInfo info) {
  AddParam(name, ParamType::kStringList, target, std::move(info));
}

void Context::Log(log::Level level, const std::string& message, std::source_location where) const {
  auto& logger = log::Global();
  if (!logger.Enabled(level)) return;
  char stamp[32];
  std::snprintf(stamp, sizeof stamp, "[%.3f s] ", now_->Seconds());
  logger.Write(level, stamp + id_ + ": " + message, where, id_);
}

Registry& Registry::Global() {
  static Registry registry;
  return registry;
}

bool Registry::Add(const std::string& type, Factory factory) {
  if (Find(type) != nullptr) {
    // Before main(): a programming error (two DRACO_REGISTER_COMPONENT with one name).
    std::fprintf(stderr, "draco: component type '%s' registered twice\n", type.c_str());
    std::abort();
  }
  entries_.push_back(Entry{type, std::move(factory)});
  return true;
}

const Registry::Entry* Registry::Find(const std::string& type) const {
  for (const auto& e : entries_) {
    if (e.type == type) return &e;
  }
  return nullptr;
}

std::vector<std::string> Registry::Types() const {
  std::vector<std::string> types;
  for (const auto& e : entries_) types.push_back(e.type);
  std::sort(types.begin(), types.end());
  return types;
}

}  // namespace draco::graph
