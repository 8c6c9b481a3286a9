// ROS 1 bag files, format 2.0 (http://wiki.ros.org/Bags/Format/2.0), read with every length,
// count and offset checked against the file before it is used (private to draco_rosbag).
//
// A bag is "#ROSBAG V2.0\n" and records: header length, header (fields "name=value", each
// with its own length), data length, data. The bag header record points at the index at the
// end of the file (connection records, then one chunk-info record per chunk); each chunk
// (none, bz2 or lz4) holds connection and message-data records and is followed by one
// index-data record per connection it holds (time and offset in the uncompressed chunk of
// each message). Open reads the bag header, the index and every chunk's index records;
// messages are read one chunk at a time (the chunk last used is kept).
//
// Memory: everything read at open is part of the file (at most its size); a chunk buffer is
// its uncompressed size, which a chunk may claim up to kMaxChunkRatio times its compressed
// bytes (and kMaxChunkBytes). Anything else is refused with BagFileError naming the record
// and its byte offset; Debian's rosbag_storage, used before, trusted those fields (fuzzing
// found out-of-bounds reads and 2 GB allocations from a 5 kB file, docs/hardening.md).
#pragma once

#include <cstdint>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace draco::rosbag::internal {

// What is wrong and where in the file; BagReader prefixes the path.
class BagFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr std::uint32_t kMaxHeaderBytes = 1u << 20;   // a record header's fields
inline constexpr std::uint64_t kMaxChunkBytes = 1ull << 30;  // uncompressed (default: 768 kB)
inline constexpr std::uint64_t kMaxChunkRatio = 16384;       // uncompressed / compressed bytes

struct BagConnection {
  std::uint32_t id = 0;
  std::string topic;
  std::string datatype;
  std::string md5sum;
  std::string definition;
};

struct BagIndexEntry {
  std::uint32_t sec = 0;  // receipt time
  std::uint32_t nsec = 0;
  std::uint32_t connection = 0;
  std::uint32_t chunk = 0;   // index into the chunks, in chunk-info order
  std::uint32_t offset = 0;  // of the message-data record in the uncompressed chunk
  std::int64_t Nanoseconds() const { return std::int64_t{sec} * 1000000000 + nsec; }
  double Seconds() const { return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec); }
};

class BagFile {
 public:
  // Reads and checks the bag header, the index and every chunk's index records.
  explicit BagFile(const std::string& path);

  const std::vector<BagConnection>& connections() const { return connections_; }
  const BagConnection* FindConnection(std::uint32_t id) const;
  // Every message of the given connections, in receipt-time order (ties: file order).
  std::vector<BagIndexEntry> Entries(const std::set<std::uint32_t>& connections) const;
  std::size_t MessageCount(std::uint32_t connection) const;
  bool empty() const { return entries_.empty(); }
  const BagIndexEntry& first() const { return entries_.front(); }  // earliest (not empty)
  const BagIndexEntry& last() const { return entries_.back(); }    // latest (not empty)

  // The serialized message an index entry points at; the bytes stay valid until the next
  // call. Throws BagFileError when the chunk does not decompress or the record is malformed.
  struct Message {
    const std::uint8_t* data = nullptr;
    std::size_t size = 0;
  };
  Message Read(const BagIndexEntry& entry);

 private:
  enum class Compression { kNone, kBz2, kLz4 };
  struct Chunk {
    std::uint64_t record_pos = 0;  // for messages
    std::uint64_t data_pos = 0;
    std::uint32_t data_len = 0;
    std::uint32_t size = 0;  // uncompressed
    Compression compression = Compression::kNone;
  };
  struct Record;

  Record ReadRecord(std::uint64_t pos, const char* what, std::string* data);
  void ReadBytes(std::uint64_t pos, void* out, std::size_t n, const char* what);
  void LoadChunk(std::uint32_t index);

  std::ifstream file_;
  std::uint64_t size_ = 0;
  std::vector<BagConnection> connections_;  // sorted by id
  std::vector<Chunk> chunks_;
  std::vector<BagIndexEntry> entries_;                   // every message, sorted
  std::map<std::uint32_t, std::size_t> message_counts_;  // by connection
  std::int64_t loaded_chunk_ = -1;
  std::vector<std::uint8_t> chunk_data_;
};

}  // namespace draco::rosbag::internal
