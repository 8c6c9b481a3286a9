#include "draco/rosbag/ros_message.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace draco::rosbag {
namespace {

constexpr int kMaxNesting = 64;
constexpr std::int64_t kMaxFixedArray = 1 << 24;
constexpr std::size_t kMaxValues = std::size_t{1} << 20;  // per message (uint8 arrays: one)

// Wire size of a builtin type; strings report their minimum (the length prefix).
std::size_t BuiltinSize(const std::string& type) {
  if (type == "bool" || type == "int8" || type == "uint8" || type == "byte" || type == "char")
    return 1;
  if (type == "int16" || type == "uint16") return 2;
  if (type == "int32" || type == "uint32" || type == "float32" || type == "string") return 4;
  if (type == "int64" || type == "uint64" || type == "float64" || type == "time" ||
      type == "duration")
    return 8;
  return 0;
}

bool IsBuiltin(const std::string& type) { return BuiltinSize(type) != 0; }

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool IsSeparator(std::string_view line) {
  return line.size() >= 3 && line.find_first_not_of('=') == std::string_view::npos;
}

std::string PackageOf(const std::string& type) {
  auto slash = type.find('/');
  return slash == std::string::npos ? std::string() : type.substr(0, slash);
}

std::string ShortName(const std::string& type) {
  auto slash = type.rfind('/');
  return slash == std::string::npos ? type : type.substr(slash + 1);
}

// Parses "type name" (arrays as type[] / type[N]); returns false for constants and blanks.
bool ParseFieldLine(std::string_view raw, const std::string& package, const std::string& owner,
                    MessageDefinition::Field* field) {
  std::string_view line = Trim(raw);
  if (line.empty() || line.front() == '#') return false;
  auto space = line.find_first_of(" \t");
  if (space == std::string_view::npos) {
    throw DecodeError("message definition of '" + owner + "': cannot parse line '" +
                      std::string(line) + "'");
  }
  std::string type(line.substr(0, space));
  std::string_view rest = Trim(line.substr(space));
  auto hash = rest.find('#');
  auto equals = rest.find('=');
  if (equals != std::string_view::npos && (hash == std::string_view::npos || equals < hash)) {
    return false;  // constant: not on the wire
  }
  if (hash != std::string_view::npos) rest = Trim(rest.substr(0, hash));
  auto name_end = rest.find_first_of(" \t");
  std::string_view name = rest.substr(0, name_end);
  if (name.empty()) {
    throw DecodeError("message definition of '" + owner + "': field without a name in line '" +
                      std::string(line) + "'");
  }
  field->name = std::string(name);
  field->is_array = false;
  field->array_size = -1;
  auto bracket = type.find('[');
  if (bracket != std::string::npos) {
    if (type.back() != ']') {
      throw DecodeError("message definition of '" + owner + "': bad array type '" + type + "'");
    }
    std::string size_text = type.substr(bracket + 1, type.size() - bracket - 2);
    field->is_array = true;
    if (!size_text.empty()) {
      std::int64_t n = 0;
      for (char c : size_text) {
        if (!std::isdigit(static_cast<unsigned char>(c)) || n > kMaxFixedArray) {
          throw DecodeError("message definition of '" + owner + "': bad array size in '" + type +
                            "'");
        }
        n = n * 10 + (c - '0');
      }
      field->array_size = n;
    }
    type = type.substr(0, bracket);
  }
  if (IsBuiltin(type)) {
    field->builtin = true;
    field->type = type;
  } else {
    field->builtin = false;
    if (type == "Header") {
      field->type = "std_msgs/Header";
    } else if (type.find('/') != std::string::npos) {
      field->type = type;
    } else {
      field->type = package.empty() ? type : package + "/" + type;
    }
  }
  return true;
}

// Bounds-checked little-endian reader.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t remaining() const { return size_ - pos_; }

  void Need(std::size_t n, const std::string& path) const {
    if (n > remaining()) {
      throw DecodeError("field '" + path + "': needs " + std::to_string(n) + " bytes at offset " +
                        std::to_string(pos_) + ", " + std::to_string(remaining()) +
                        " left (message truncated?)");
    }
  }
  std::uint64_t Unsigned(std::size_t n, const std::string& path) {
    Need(n, path);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(data_[pos_ + i]) << (8 * i);
    pos_ += n;
    return v;
  }
  std::int64_t Signed(std::size_t n, const std::string& path) {
    std::uint64_t v = Unsigned(n, path);
    if (n < 8 && (v >> (8 * n - 1)) != 0) v |= ~std::uint64_t{0} << (8 * n);
    return static_cast<std::int64_t>(v);
  }
  const std::uint8_t* Take(std::size_t n, const std::string& path) {
    Need(n, path);
    const std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

class Decoder {
 public:
  // Values decoded at most: two a byte (every value but an empty message takes at least a
  // byte, so a real message stays far below; fixed arrays of empty messages, nested, each up
  // to 2^24, would otherwise make a few bytes of definition decode to billions of values),
  // and kMaxValues a message (a decoded value takes 40 to 72 bytes: a message of a
  // decompressed chunk, itself up to 16384 times its bytes in the file, stays under 80 MB).
  Decoder(const MessageDefinition& def, Cursor* cursor)
      : def_(def),
        in_(*cursor),
        budget_(std::min<std::size_t>(2 * cursor->remaining() + 1024, kMaxValues)) {}

  RosValue Message(const std::string& type, const std::string& path, int depth) {
    if (depth > kMaxNesting) throw DecodeError("field '" + path + "': nesting too deep");
    Spend(path);
    const auto* fields = def_.FieldsOf(type);
    if (fields == nullptr) {
      throw DecodeError("field '" + path + "': type '" + type + "' has no definition");
    }
    RosValue::Fields out;
    out.reserve(fields->size());
    for (const auto& f : *fields) {
      std::string sub = path.empty() ? f.name : path + "." + f.name;
      out.emplace_back(f.name, Field(f, sub, depth));
    }
    return RosValue(std::move(out));
  }

 private:
  RosValue Field(const MessageDefinition::Field& f, const std::string& path, int depth) {
    if (!f.is_array) return Element(f, path, depth);
    std::uint64_t count = f.array_size >= 0 ? static_cast<std::uint64_t>(f.array_size)
                                            : in_.Unsigned(4, path + " (array length)");
    if (f.builtin && (f.type == "uint8" || f.type == "char")) {
      const std::uint8_t* p = in_.Take(count, path);
      return RosValue(RosValue::Bytes(p, p + count));
    }
    std::size_t min_size = MinSize(f.type, depth);
    if ((min_size == 0 && count > static_cast<std::uint64_t>(kMaxFixedArray)) ||
        (min_size > 0 && count > in_.remaining() / min_size)) {
      throw DecodeError("field '" + path + "': array of " + std::to_string(count) +
                        " elements cannot fit in the " + std::to_string(in_.remaining()) +
                        " bytes left (message truncated?)");
    }
    RosValue::Array items;
    items.reserve(std::min<std::uint64_t>(count, budget_));
    for (std::uint64_t i = 0; i < count; ++i) {
      items.push_back(Element(f, path + "[" + std::to_string(i) + "]", depth));
    }
    return RosValue(std::move(items));
  }

  void Spend(const std::string& path) {
    if (budget_ == 0) {
      throw DecodeError("field '" + path + "': more values than a message of this size can " +
                        "hold (arrays of empty messages?)");
    }
    --budget_;
  }

  RosValue Element(const MessageDefinition::Field& f, const std::string& path, int depth) {
    if (!f.builtin) return Message(f.type, path, depth + 1);
    Spend(path);
    const std::string& t = f.type;
    if (t == "float64") {
      std::uint64_t bits = in_.Unsigned(8, path);
      double v;
      std::memcpy(&v, &bits, sizeof v);
      return RosValue(v);
    }
    if (t == "float32") {
      auto bits = static_cast<std::uint32_t>(in_.Unsigned(4, path));
      float v;
      std::memcpy(&v, &bits, sizeof v);
      return RosValue(static_cast<double>(v));
    }
    if (t == "string") {
      std::uint64_t n = in_.Unsigned(4, path + " (string length)");
      const std::uint8_t* p = in_.Take(n, path);
      return RosValue(std::string(reinterpret_cast<const char*>(p), n));
    }
    if (t == "time") {
      RosTime v;
      v.sec = static_cast<std::int64_t>(in_.Unsigned(4, path + ".secs"));
      v.nsec = static_cast<std::int64_t>(in_.Unsigned(4, path + ".nsecs"));
      return RosValue(v);
    }
    if (t == "duration") {
      RosTime v;
      v.sec = in_.Signed(4, path + ".secs");
      v.nsec = in_.Signed(4, path + ".nsecs");
      return RosValue(v);
    }
    std::size_t n = BuiltinSize(t);
    if (t == "int8" || t == "byte" || t == "int16" || t == "int32" || t == "int64") {
      return RosValue(in_.Signed(n, path));
    }
    return RosValue(in_.Unsigned(n, path));  // bool, char, uintN
  }

  std::size_t MinSize(const std::string& type, int depth) {
    if (IsBuiltin(type)) return BuiltinSize(type);
    auto it = min_sizes_.find(type);
    if (it != min_sizes_.end()) return it->second;
    if (depth > kMaxNesting) throw DecodeError("type '" + type + "': nesting too deep");
    std::size_t total = 0;
    if (const auto* fields = def_.FieldsOf(type)) {
      for (const auto& f : *fields) {
        if (!f.is_array) {
          total += MinSize(f.type, depth + 1);
        } else if (f.array_size < 0) {
          total += 4;
        } else {
          total += static_cast<std::size_t>(f.array_size) * MinSize(f.type, depth + 1);
        }
      }
    }
    min_sizes_[type] = total;
    return total;
  }

  const MessageDefinition& def_;
  Cursor& in_;
  std::size_t budget_;
  std::map<std::string, std::size_t> min_sizes_;
};

}  // namespace

bool RosValue::IsNumber() const {
  return std::holds_alternative<std::int64_t>(value_) ||
         std::holds_alternative<std::uint64_t>(value_) || std::holds_alternative<double>(value_);
}

std::optional<double> RosValue::AsNumber() const {
  if (const auto* v = std::get_if<double>(&value_)) return *v;
  if (const auto* v = std::get_if<std::int64_t>(&value_)) return static_cast<double>(*v);
  if (const auto* v = std::get_if<std::uint64_t>(&value_)) return static_cast<double>(*v);
  return std::nullopt;
}

std::optional<std::int64_t> RosValue::AsInteger() const {
  if (const auto* v = std::get_if<std::int64_t>(&value_)) return *v;
  if (const auto* v = std::get_if<std::uint64_t>(&value_)) return static_cast<std::int64_t>(*v);
  return std::nullopt;
}

const RosValue* RosValue::Find(std::string_view path) const {
  const RosValue* node = this;
  while (!path.empty()) {
    auto dot = path.find('.');
    std::string_view name = path.substr(0, dot);
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
    const auto* fields = node->AsFields();
    if (fields == nullptr) return nullptr;
    const RosValue* next = nullptr;
    for (const auto& [field_name, value] : *fields) {
      if (field_name == name) {
        next = &value;
        break;
      }
    }
    if (next == nullptr) return nullptr;
    node = next;
  }
  return node;
}

double RosValue::NumberOr(std::string_view path, double fallback) const {
  return Number(path).value_or(fallback);
}

std::optional<double> RosValue::Number(std::string_view path) const {
  const RosValue* v = Find(path);
  return v == nullptr ? std::nullopt : v->AsNumber();
}

std::optional<double> RosValue::TimeSeconds(std::string_view path) const {
  const RosValue* v = Find(path);
  if (v == nullptr || v->AsTime() == nullptr) return std::nullopt;
  return v->AsTime()->Seconds();
}

std::optional<std::vector<double>> RosValue::Numbers(std::string_view path) const {
  const RosValue* v = Find(path);
  if (v == nullptr) return std::nullopt;
  std::vector<double> out;
  if (const auto* bytes = v->AsBytes()) {
    out.assign(bytes->begin(), bytes->end());
    return out;
  }
  const auto* items = v->AsArray();
  if (items == nullptr) return std::nullopt;
  out.reserve(items->size());
  for (const auto& item : *items) {
    auto x = item.AsNumber();
    if (!x) return std::nullopt;
    out.push_back(*x);
  }
  return out;
}

MessageDefinition MessageDefinition::Parse(const std::string& root_type, std::string_view text) {
  MessageDefinition def;
  def.root_type_ = root_type;
  std::string current = root_type;
  bool expect_msg_line = false;
  def.types_[current];
  std::size_t start = 0;
  while (start <= text.size()) {
    auto end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = Trim(text.substr(start, end - start));
    start = end + 1;
    if (IsSeparator(line)) {
      expect_msg_line = true;
      continue;
    }
    if (expect_msg_line) {
      if (line.empty()) continue;
      if (line.substr(0, 4) != "MSG:") {
        throw DecodeError("message definition of '" + root_type +
                          "': expected 'MSG: type' after a separator, got '" + std::string(line) +
                          "'");
      }
      current = std::string(Trim(line.substr(4)));
      if (current == "Header") current = "std_msgs/Header";
      def.types_[current];
      expect_msg_line = false;
      continue;
    }
    Field field;
    if (ParseFieldLine(line, PackageOf(current), current, &field)) {
      def.types_[current].push_back(std::move(field));
    }
  }
  // Resolve types named without their package to a defined type of the same short name (the
  // last in name order when several have it). One lookup table: a long definition text must
  // not take quadratic time.
  std::map<std::string, std::string> by_short_name;
  for (const auto& entry : def.types_) by_short_name[ShortName(entry.first)] = entry.first;
  for (auto& [type, fields] : def.types_) {
    for (auto& f : fields) {
      if (f.builtin || def.types_.count(f.type) != 0) continue;
      std::string match;
      if (auto it = by_short_name.find(ShortName(f.type)); it != by_short_name.end()) {
        match = it->second;
      }
      if (match.empty()) {
        throw DecodeError("message definition of '" + root_type + "': type '" + f.type +
                          "' of field '" + type + "." + f.name + "' has no definition");
      }
      f.type = match;
    }
  }
  return def;
}

const std::vector<MessageDefinition::Field>* MessageDefinition::FieldsOf(
    const std::string& type) const {
  auto it = types_.find(type);
  return it == types_.end() ? nullptr : &it->second;
}

bool MessageDefinition::HasField(std::string_view path) const {
  std::string type = root_type_;
  while (!path.empty()) {
    auto dot = path.find('.');
    std::string_view name = path.substr(0, dot);
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
    const auto* fields = FieldsOf(type);
    if (fields == nullptr) return false;
    const Field* found = nullptr;
    for (const auto& f : *fields) {
      if (f.name == name) found = &f;
    }
    if (found == nullptr) return false;
    if (!path.empty() && (found->builtin || found->is_array)) return false;
    type = found->type;
  }
  return true;
}

RosValue MessageDefinition::Decode(const std::uint8_t* data, std::size_t size) const {
  Cursor cursor(data, size);
  Decoder decoder(*this, &cursor);
  return decoder.Message(root_type_, "", 0);
}

}  // namespace draco::rosbag
