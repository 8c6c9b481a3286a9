// MessageDefinition parsing and the definition-driven decoder, on hand-serialized bytes.
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "draco/rosbag/ros_message.hpp"

namespace draco::rosbag {
namespace {

// Little-endian writer for hand-made messages.
struct Bytes {
  std::vector<std::uint8_t> data;
  void U(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) data.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void F64(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    U(bits, 8);
  }
  void F32(float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    U(bits, 4);
  }
  void Str(const std::string& s) {
    U(s.size(), 4);
    data.insert(data.end(), s.begin(), s.end());
  }
};

const char* kDefinition =
    "# A test message\n"
    "Header header\n"
    "int8 KIND_A = 1   # a constant, not on the wire\n"
    "string NAME=x#y\n"
    "Inner inner  # comment\n"
    "int16[] values\n"
    "float64[2] pair\n"
    "uint8[] blob\n"
    "pkg/Inner[] inners\n"
    "duration wait\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\n"
    "uint32 seq\n"
    "time stamp\n"
    "string frame_id\n"
    "================================================================================\n"
    "MSG: pkg/Inner\n"
    "float32 level\n"
    "bool flag\n";

Bytes ValidMessage() {
  Bytes b;
  b.U(7, 4);           // header.seq
  b.U(1600000000, 4);  // header.stamp.secs
  b.U(500000000, 4);   // header.stamp.nsecs
  b.Str("sonar");      // header.frame_id
  b.F32(2.5f);         // inner.level
  b.U(1, 1);           // inner.flag
  b.U(3, 4);           // values: 3 x int16
  b.U(static_cast<std::uint16_t>(-6500), 2);
  b.U(0, 2);
  b.U(6500, 2);
  b.F64(1.25);  // pair
  b.F64(-2.0);
  b.U(2, 4);  // blob
  b.U(0xAB, 1);
  b.U(0xCD, 1);
  b.U(1, 4);  // inners: one element
  b.F32(-1.0f);
  b.U(0, 1);
  b.U(static_cast<std::uint32_t>(-3), 4);  // wait.secs
  b.U(0, 4);                               // wait.nsecs
  return b;
}

TEST(MessageDefinition, ParsesFieldsConstantsArraysAndSections) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  const auto* fields = def.FieldsOf("pkg/Test");
  ASSERT_NE(fields, nullptr);
  ASSERT_EQ(fields->size(), 7u);  // constants skipped
  EXPECT_EQ((*fields)[0].type, "std_msgs/Header");
  EXPECT_EQ((*fields)[1].type, "pkg/Inner");  // resolved in the owner's package
  EXPECT_TRUE((*fields)[2].is_array);
  EXPECT_EQ((*fields)[2].array_size, -1);
  EXPECT_EQ((*fields)[3].array_size, 2);
  EXPECT_TRUE(def.HasField("header.stamp"));
  EXPECT_TRUE(def.HasField("inner.flag"));
  EXPECT_FALSE(def.HasField("inner.missing"));
  EXPECT_FALSE(def.HasField("values.x"));
}

TEST(MessageDefinition, DecodesEveryKindOfField) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  Bytes b = ValidMessage();
  RosValue v = def.Decode(b.data.data(), b.data.size());
  EXPECT_EQ(v.NumberOr("header.seq", -1), 7);
  EXPECT_DOUBLE_EQ(*v.TimeSeconds("header.stamp"), 1600000000.5);
  EXPECT_EQ(*v.Find("header.frame_id")->AsString(), "sonar");
  EXPECT_DOUBLE_EQ(*v.Number("inner.level"), 2.5);
  EXPECT_EQ(*v.Number("inner.flag"), 1.0);
  EXPECT_EQ(*v.Numbers("values"), (std::vector<double>{-6500, 0, 6500}));
  EXPECT_EQ(*v.Numbers("pair"), (std::vector<double>{1.25, -2.0}));
  EXPECT_EQ(*v.Find("blob")->AsBytes(), (std::vector<std::uint8_t>{0xAB, 0xCD}));
  ASSERT_EQ(v.Find("inners")->AsArray()->size(), 1u);
  EXPECT_DOUBLE_EQ(*v.Find("inners")->AsArray()->at(0).Number("level"), -1.0);
  EXPECT_EQ(v.Find("wait")->AsTime()->sec, -3);
  // Absent fields read as absent, with defaults.
  EXPECT_EQ(v.Find("part_number"), nullptr);
  EXPECT_EQ(v.NumberOr("part_number", 42.0), 42.0);
  EXPECT_FALSE(v.Number("header.frame_id").has_value());
}

TEST(MessageDefinition, TruncatedDataNamesTheField) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  Bytes b = ValidMessage();
  // Cut inside values[1] (header 4+8+4+5, inner 5, count 4, values[0] 2).
  std::size_t cut = 4 + 8 + 4 + 5 + 5 + 4 + 2 + 1;
  try {
    def.Decode(b.data.data(), 4 + 8 + 2);
    FAIL() << "no error";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'header.frame_id (string length)'"),
              std::string::npos)
        << e.what();
  }
  try {
    def.Decode(b.data.data(), cut);
    FAIL() << "no error";
  } catch (const DecodeError& e) {
    // The array is checked against the bytes left before its elements are read.
    EXPECT_NE(std::string(e.what()).find("field 'values': array of 3"), std::string::npos)
        << e.what();
  }
}

TEST(MessageDefinition, EveryTruncationIsAnErrorNeverACrash) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  Bytes b = ValidMessage();
  for (std::size_t n = 0; n < b.data.size(); ++n) {
    EXPECT_THROW(def.Decode(b.data.data(), n), DecodeError) << n;
  }
  EXPECT_NO_THROW(def.Decode(b.data.data(), b.data.size()));
}

TEST(MessageDefinition, ImpossibleArrayLengthIsRejectedBeforeAllocating) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  Bytes b = ValidMessage();
  std::size_t values_count_at = 4 + 8 + 4 + 5 + 5;
  b.data[values_count_at + 3] = 0x7f;  // ~2 billion int16 values
  try {
    def.Decode(b.data.data(), b.data.size());
    FAIL() << "no error";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'values'"), std::string::npos) << e.what();
  }
}

// Memory bound (docs/hardening.md): fixed arrays of empty messages take no bytes, so a short
// definition could make a few bytes decode to billions of values (16M x 16M here); the
// decoder stops at two values per byte of the message (plus 1024).
TEST(MessageDefinition, ArraysOfEmptyMessagesCannotMultiplyValues) {
  const auto def = MessageDefinition::Parse(
      "pkg/Bomb",
      "Outer[16000000] outer\n=====\nMSG: pkg/Outer\nEmpty[16000000] inner\n"
      "=====\nMSG: pkg/Empty\n");
  const std::uint8_t data[8] = {};
  try {
    def.Decode(data, sizeof(data));
    FAIL() << "no error";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("more values than a message of this size can hold"),
              std::string::npos)
        << e.what();
  }
  // At most 2^20 values a message, whatever its size (int8 arrays: 40 bytes a value).
  const auto bytes8 = MessageDefinition::Parse("pkg/I", "int8[] a\n");
  std::vector<std::uint8_t> big(4 + (2u << 20), 0);
  big[2] = 0x20;  // 2^21 elements
  EXPECT_THROW(bytes8.Decode(big.data(), big.size()), DecodeError);
  // A real message of many small values is far below the bound.
  const auto floats = MessageDefinition::Parse("pkg/F", "uint8[3000] a\nint16[1000] b\n");
  const std::vector<std::uint8_t> bytes(5000, 1);
  EXPECT_NO_THROW(floats.Decode(bytes.data(), bytes.size()));
}

// A long definition text resolves its types in n log n, not n^2: types named without their
// package (resolved by their short name) were each compared with every type defined.
TEST(MessageDefinition, ManyTypesResolveQuickly) {
  std::string text = "T0 first\n";
  for (int i = 0; i < 20000; ++i) {
    text += "=====\nMSG: other" + std::to_string(i) + "/T" + std::to_string(i) + "\nT" +
            std::to_string(i + 1) + " next\n";
  }
  text += "=====\nMSG: other20000/T20000\nfloat64 x\n";
  const auto start = std::chrono::steady_clock::now();
  const auto def = MessageDefinition::Parse("pkg/Root", text);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  EXPECT_TRUE(def.HasField("first.next.next.next"));
}

TEST(MessageDefinition, CorruptBytesNeverCrash) {
  auto def = MessageDefinition::Parse("pkg/Test", kDefinition);
  Bytes good = ValidMessage();
  std::uint32_t state = 12345;
  for (int trial = 0; trial < 2000; ++trial) {
    auto data = good.data;
    for (int k = 0; k < 3; ++k) {
      state = state * 1664525u + 1013904223u;
      data[(state >> 8) % data.size()] = static_cast<std::uint8_t>(state >> 24);
    }
    try {
      def.Decode(data.data(), data.size());
    } catch (const DecodeError&) {
    }
  }
}

TEST(MessageDefinition, MissingTypeAndBadSyntaxAreErrors) {
  EXPECT_THROW(MessageDefinition::Parse("pkg/A", "Unknown thing\n"), DecodeError);
  EXPECT_THROW(MessageDefinition::Parse("pkg/A", "float64\n"), DecodeError);
  EXPECT_THROW(MessageDefinition::Parse("pkg/A", "float64[x] a\n"), DecodeError);
  EXPECT_THROW(MessageDefinition::Parse("pkg/A", "float64 a\n=====\nnot a msg line\n"),
               DecodeError);
}

}  // namespace
}  // namespace draco::rosbag
