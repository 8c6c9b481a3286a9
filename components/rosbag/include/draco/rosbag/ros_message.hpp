// ROS 1 messages decoded by the definition text a bag stores with each connection, without
// generated message classes: MessageDefinition parses the `.msg` text (with its `MSG:`
// sections), Decode() turns serialized bytes into a RosValue tree, and fields are then
// looked up by name, so a field an older layout lacks simply reads as absent.
//
// Wire format (ROS 1): little-endian primitives; string = uint32 length + bytes; variable
// array = uint32 count + elements; fixed array = elements only; time/duration = two 32-bit
// integers (seconds, nanoseconds); nested messages inline, no padding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace draco::rosbag {

// A malformed definition or message. The message names the field path, e.g.
// "field 'ping.data': needs 4 bytes at offset 120, 2 left".
class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ROS time or duration as stored: whole seconds and nanoseconds.
struct RosTime {
  std::int64_t sec = 0;
  std::int64_t nsec = 0;
  double Seconds() const { return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec); }
};

// One decoded value: a number, string, byte array (uint8/char/byte arrays), time, array of
// values, or message (fields in definition order).
class RosValue {
 public:
  using Bytes = std::vector<std::uint8_t>;
  using Array = std::vector<RosValue>;
  using Fields = std::vector<std::pair<std::string, RosValue>>;

  RosValue() = default;
  explicit RosValue(std::int64_t v) : value_(v) {}
  explicit RosValue(std::uint64_t v) : value_(v) {}
  explicit RosValue(double v) : value_(v) {}
  explicit RosValue(std::string v) : value_(std::move(v)) {}
  explicit RosValue(Bytes v) : value_(std::move(v)) {}
  explicit RosValue(RosTime v) : value_(v) {}
  explicit RosValue(Array v) : value_(std::move(v)) {}
  explicit RosValue(Fields v) : value_(std::move(v)) {}

  bool IsNumber() const;
  bool IsMessage() const { return std::holds_alternative<Fields>(value_); }
  // The number as a double (integers converted); nullopt when not a number.
  std::optional<double> AsNumber() const;
  std::optional<std::int64_t> AsInteger() const;  // integers only
  const std::string* AsString() const { return std::get_if<std::string>(&value_); }
  const Bytes* AsBytes() const { return std::get_if<Bytes>(&value_); }
  const RosTime* AsTime() const { return std::get_if<RosTime>(&value_); }
  const Array* AsArray() const { return std::get_if<Array>(&value_); }
  const Fields* AsFields() const { return std::get_if<Fields>(&value_); }

  // The value at a dotted path of field names ("fire_msg.gamma"); nullptr when any part is
  // missing or not a message.
  const RosValue* Find(std::string_view path) const;
  // Convenience lookups with a default for absent fields (or fields of another kind).
  double NumberOr(std::string_view path, double fallback) const;
  std::optional<double> Number(std::string_view path) const;
  std::optional<double> TimeSeconds(std::string_view path) const;
  // A numeric array (or byte array) as doubles; nullopt when absent or not numeric.
  std::optional<std::vector<double>> Numbers(std::string_view path) const;

 private:
  std::variant<std::monostate, std::int64_t, std::uint64_t, double, std::string, Bytes, RosTime,
               Array, Fields>
      value_;
};

// The parsed definition of one message type and every type it uses.
class MessageDefinition {
 public:
  struct Field {
    std::string name;
    std::string type;  // builtin ("float64", "time", ...) or full message name
    bool builtin = false;
    bool is_array = false;
    std::int64_t array_size = -1;  // fixed array length; -1 for a variable array
  };

  // root_type: the connection's datatype ("sonar_oculus/OculusPing"); text: its stored
  // message_definition. Throws DecodeError on syntax errors or a type without definition.
  static MessageDefinition Parse(const std::string& root_type, std::string_view text);

  const std::string& root_type() const { return root_type_; }
  // Fields of a message type (root or nested); nullptr when unknown.
  const std::vector<Field>* FieldsOf(const std::string& type) const;
  // Whether the root type, or a type it uses, has a field of that name at a dotted path.
  bool HasField(std::string_view path) const;

  // Decodes one serialized message of the root type. Throws DecodeError naming the field
  // when the data is truncated or an array length is impossible. Extra trailing bytes are
  // ignored (a newer writer may have appended fields).
  RosValue Decode(const std::uint8_t* data, std::size_t size) const;

 private:
  std::string root_type_;
  std::map<std::string, std::vector<Field>> types_;
};

}  // namespace draco::rosbag
