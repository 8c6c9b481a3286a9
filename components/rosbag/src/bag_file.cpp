#include "bag_file.hpp"

#include <bzlib.h>
#include <lz4frame.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>

namespace draco::rosbag::internal {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicBytes = sizeof(kMagic) - 1;

constexpr std::uint8_t kOpMessageData = 0x02;
constexpr std::uint8_t kOpBagHeader = 0x03;
constexpr std::uint8_t kOpIndexData = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;

std::uint32_t U32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) |
         (std::uint32_t{p[3]} << 24);
}
std::uint64_t U64(const std::uint8_t* p) { return U32(p) | (std::uint64_t{U32(p + 4)} << 32); }

[[noreturn]] void Fail(const std::string& what) { throw BagFileError(what); }

// "name=value" fields of a record header (or of a connection record's data).
using Fields = std::map<std::string, std::string>;

Fields ParseFields(const std::uint8_t* p, std::size_t n, const std::string& where) {
  Fields fields;
  std::size_t at = 0;
  while (at < n) {
    if (n - at < 4) Fail(where + ": header field length cut short");
    const std::uint32_t len = U32(p + at);
    at += 4;
    if (len > n - at) {
      Fail(where + ": header field of " + std::to_string(len) + " bytes, " +
           std::to_string(n - at) + " left in the header");
    }
    const auto* begin = reinterpret_cast<const char*>(p + at);
    const auto* eq = static_cast<const char*>(std::memchr(begin, '=', len));
    if (eq == nullptr) Fail(where + ": header field without '='");
    fields[std::string(begin, eq)] = std::string(eq + 1, begin + len);
    at += len;
  }
  return fields;
}

const std::string& Field(const Fields& f, const char* name, const std::string& where) {
  auto it = f.find(name);
  if (it == f.end()) Fail(where + ": no '" + name + "' field");
  return it->second;
}
std::uint8_t FieldU8(const Fields& f, const char* name, const std::string& where) {
  const std::string& v = Field(f, name, where);
  if (v.size() != 1) Fail(where + ": field '" + name + "' must be 1 byte");
  return static_cast<std::uint8_t>(v[0]);
}
std::uint32_t FieldU32(const Fields& f, const char* name, const std::string& where) {
  const std::string& v = Field(f, name, where);
  if (v.size() != 4) Fail(where + ": field '" + name + "' must be 4 bytes");
  return U32(reinterpret_cast<const std::uint8_t*>(v.data()));
}
std::uint64_t FieldU64(const Fields& f, const char* name, const std::string& where) {
  const std::string& v = Field(f, name, where);
  if (v.size() != 8) Fail(where + ": field '" + name + "' must be 8 bytes");
  return U64(reinterpret_cast<const std::uint8_t*>(v.data()));
}

std::string At(const char* what, std::uint64_t pos) {
  return std::string(what) + " at byte " + std::to_string(pos);
}

}  // namespace

struct BagFile::Record {
  std::uint64_t pos = 0;
  std::uint8_t op = 0;
  Fields fields;
  std::uint64_t data_pos = 0;
  std::uint32_t data_len = 0;
  std::uint64_t end = 0;  // first byte after the record
  std::string where;
};

void BagFile::ReadBytes(std::uint64_t pos, void* out, std::size_t n, const char* what) {
  if (pos > size_ || n > size_ - pos) {
    Fail(At(what, pos) + ": needs " + std::to_string(n) + " bytes, the file ends " +
         std::to_string(size_ - std::min(pos, size_)) + " bytes later (truncated?)");
  }
  file_.clear();
  file_.seekg(static_cast<std::streamoff>(pos));
  file_.read(static_cast<char*>(out), static_cast<std::streamsize>(n));
  if (static_cast<std::size_t>(file_.gcount()) != n) Fail(At(what, pos) + ": read error");
}

// The record at pos: its header fields, and its data into *data (when not null).
BagFile::Record BagFile::ReadRecord(std::uint64_t pos, const char* what, std::string* data) {
  Record r;
  r.pos = pos;
  r.where = At(what, pos);
  std::uint8_t len[4];
  ReadBytes(pos, len, 4, what);
  const std::uint32_t header_len = U32(len);
  if (header_len > kMaxHeaderBytes || header_len > size_ - pos - 4) {
    Fail(r.where + ": header of " + std::to_string(header_len) + " bytes does not fit (" +
         std::to_string(size_ - pos - 4) + " bytes left in the file)");
  }
  std::vector<std::uint8_t> header(header_len);
  ReadBytes(pos + 4, header.data(), header_len, what);
  r.fields = ParseFields(header.data(), header_len, r.where);
  r.op = FieldU8(r.fields, "op", r.where);
  ReadBytes(pos + 4 + header_len, len, 4, what);
  r.data_len = U32(len);
  r.data_pos = pos + 8 + header_len;
  if (r.data_len > size_ - r.data_pos) {
    Fail(r.where + ": data of " + std::to_string(r.data_len) + " bytes, " +
         std::to_string(size_ - r.data_pos) + " left in the file (truncated?)");
  }
  r.end = r.data_pos + r.data_len;
  if (data != nullptr) {
    data->resize(r.data_len);
    ReadBytes(r.data_pos, data->data(), r.data_len, what);
  }
  return r;
}

BagFile::BagFile(const std::string& path) : file_(path, std::ios::binary) {
  std::error_code error;
  if (!file_ || !std::filesystem::is_regular_file(path, error)) {
    Fail("cannot open file (missing, unreadable or not a regular file)");
  }
  size_ = std::filesystem::file_size(path, error);
  if (error) Fail("cannot tell the file's size (" + error.message() + ")");

  char magic[kMagicBytes] = {};
  if (size_ < kMagicBytes) Fail("not a ROS bag: " + std::to_string(size_) + " bytes");
  ReadBytes(0, magic, kMagicBytes, "format line");
  if (std::memcmp(magic, kMagic, kMagicBytes) != 0) {
    if (std::memcmp(magic, "#ROSBAG V", 9) == 0) {
      Fail("bag format '" + std::string(magic + 1, kMagicBytes - 2) +
           "' is not supported (this reader reads format 2.0, ROS 1 since 2010)");
    }
    Fail("not a ROS bag: no '#ROSBAG V2.0' line at the start");
  }

  const Record header = ReadRecord(kMagicBytes, "bag header", nullptr);
  if (header.op != kOpBagHeader) Fail(header.where + ": expected the bag header record (op 3)");
  const std::uint64_t index_pos = FieldU64(header.fields, "index_pos", header.where);
  const std::uint32_t conn_count = FieldU32(header.fields, "conn_count", header.where);
  const std::uint32_t chunk_count = FieldU32(header.fields, "chunk_count", header.where);
  if (index_pos == 0) {
    Fail("the bag has no index (recording interrupted? 'rosbag reindex' writes one)");
  }
  if (index_pos >= size_) {
    Fail("the index is at byte " + std::to_string(index_pos) + ", the file ends at byte " +
         std::to_string(size_) + ": the bag is truncated");
  }
  if (index_pos < header.end) {
    Fail(header.where + ": index position " + std::to_string(index_pos) +
         " is outside the file's records (" + std::to_string(header.end) + " to " +
         std::to_string(size_) + ")");
  }

  // The index: connection records, then chunk-info records. The counts are only loop
  // bounds: every record read is checked against the file, nothing is sized by them.
  std::uint64_t pos = index_pos;
  std::string data;
  for (std::uint32_t i = 0; i < conn_count; ++i) {
    const Record r = ReadRecord(pos, "connection record", &data);
    if (r.op != kOpConnection) Fail(r.where + ": expected a connection record (op 7)");
    BagConnection c;
    c.id = FieldU32(r.fields, "conn", r.where);
    c.topic = Field(r.fields, "topic", r.where);
    const Fields info =
        ParseFields(reinterpret_cast<const std::uint8_t*>(data.data()), data.size(), r.where);
    c.datatype = Field(info, "type", r.where);
    c.md5sum = Field(info, "md5sum", r.where);
    c.definition = Field(info, "message_definition", r.where);
    connections_.push_back(std::move(c));
    pos = r.end;
  }
  std::stable_sort(connections_.begin(), connections_.end(),
                   [](const auto& a, const auto& b) { return a.id < b.id; });
  for (std::size_t i = 1; i < connections_.size(); ++i) {
    if (connections_[i].id == connections_[i - 1].id) {
      Fail("the index defines connection " + std::to_string(connections_[i].id) + " twice");
    }
  }
  struct ChunkInfo {
    std::uint64_t chunk_pos = 0;
    std::uint32_t connections = 0;
    std::string where;
  };
  std::vector<ChunkInfo> infos;
  for (std::uint32_t i = 0; i < chunk_count; ++i) {
    const Record r = ReadRecord(pos, "chunk info record", nullptr);
    if (r.op != kOpChunkInfo) Fail(r.where + ": expected a chunk info record (op 6)");
    if (FieldU32(r.fields, "ver", r.where) != 1) Fail(r.where + ": chunk info version is not 1");
    ChunkInfo info;
    info.chunk_pos = FieldU64(r.fields, "chunk_pos", r.where);
    info.connections = FieldU32(r.fields, "count", r.where);
    info.where = r.where;
    if (r.data_len != std::uint64_t{info.connections} * 8) {
      Fail(r.where + ": " + std::to_string(r.data_len) + " data bytes for " +
           std::to_string(info.connections) + " connections (8 bytes each)");
    }
    infos.push_back(std::move(info));
    pos = r.end;
  }

  // Each chunk's header, then its index records (one per connection it holds). Chunks come in
  // file order and do not overlap, so no index byte is read twice: at most one entry per 12
  // bytes of the file.
  std::uint64_t chunks_end = header.end;  // end of the previous chunk's index records
  for (const ChunkInfo& info : infos) {
    if (info.chunk_pos < chunks_end || info.chunk_pos >= index_pos) {
      Fail(info.where + ": chunk position " + std::to_string(info.chunk_pos) +
           " is not after the previous chunk (which ends at byte " + std::to_string(chunks_end) +
           ") and before the index (byte " + std::to_string(index_pos) + ")");
    }
    const Record r = ReadRecord(info.chunk_pos, "chunk", nullptr);
    if (r.op != kOpChunk) Fail(r.where + ": expected a chunk record (op 5)");
    Chunk chunk;
    chunk.record_pos = r.pos;
    chunk.data_pos = r.data_pos;
    chunk.data_len = r.data_len;
    chunk.size = FieldU32(r.fields, "size", r.where);
    const std::string& compression = Field(r.fields, "compression", r.where);
    if (compression == "none") {
      chunk.compression = Compression::kNone;
      if (chunk.size != chunk.data_len) {
        Fail(r.where + ": uncompressed chunk of " + std::to_string(chunk.data_len) +
             " bytes says it holds " + std::to_string(chunk.size));
      }
    } else if (compression == "bz2" || compression == "lz4") {
      chunk.compression = compression == "bz2" ? Compression::kBz2 : Compression::kLz4;
      if (chunk.size > kMaxChunkBytes || chunk.size > kMaxChunkRatio * chunk.data_len) {
        Fail(r.where + ": " + compression + " chunk of " + std::to_string(chunk.data_len) +
             " bytes claims " + std::to_string(chunk.size) +
             " bytes uncompressed (implausible: at most " + std::to_string(kMaxChunkRatio) +
             " times, and 1 GiB)");
      }
    } else {
      Fail(r.where + ": unknown chunk compression '" + compression +
           "' (expected none, bz2 or lz4)");
    }
    const auto chunk_index = static_cast<std::uint32_t>(chunks_.size());
    chunks_.push_back(chunk);
    std::uint64_t at = r.end;
    std::string entries;
    for (std::uint32_t k = 0; k < info.connections; ++k) {
      const Record ir = ReadRecord(at, "index record", &entries);
      if (ir.op != kOpIndexData) Fail(ir.where + ": expected an index record (op 4)");
      if (FieldU32(ir.fields, "ver", ir.where) != 1) Fail(ir.where + ": index version is not 1");
      const std::uint32_t conn = FieldU32(ir.fields, "conn", ir.where);
      const std::uint32_t count = FieldU32(ir.fields, "count", ir.where);
      if (FindConnection(conn) == nullptr) {
        Fail(ir.where + ": connection " + std::to_string(conn) + " is not in the bag's index");
      }
      if (ir.data_len != std::uint64_t{count} * 12) {
        Fail(ir.where + ": " + std::to_string(ir.data_len) + " data bytes for " +
             std::to_string(count) + " messages (12 bytes each)");
      }
      const auto* e = reinterpret_cast<const std::uint8_t*>(entries.data());
      for (std::uint32_t m = 0; m < count; ++m, e += 12) {
        BagIndexEntry entry;
        entry.sec = U32(e);
        entry.nsec = U32(e + 4);
        entry.offset = U32(e + 8);
        entry.connection = conn;
        entry.chunk = chunk_index;
        if (entry.offset >= chunk.size) {
          Fail(ir.where + ": message " + std::to_string(m) + " at offset " +
               std::to_string(entry.offset) + " of a " + std::to_string(chunk.size) +
               "-byte chunk");
        }
        entries_.push_back(entry);
        ++message_counts_[conn];
      }
      at = ir.end;
    }
    chunks_end = at;
  }
  std::stable_sort(entries_.begin(), entries_.end(), [](const auto& a, const auto& b) {
    const auto ta = a.Nanoseconds(), tb = b.Nanoseconds();
    if (ta != tb) return ta < tb;
    if (a.chunk != b.chunk) return a.chunk < b.chunk;
    return a.offset < b.offset;
  });
}

const BagConnection* BagFile::FindConnection(std::uint32_t id) const {
  auto it = std::lower_bound(connections_.begin(), connections_.end(), id,
                             [](const BagConnection& c, std::uint32_t v) { return c.id < v; });
  return it != connections_.end() && it->id == id ? &*it : nullptr;
}

std::vector<BagIndexEntry> BagFile::Entries(const std::set<std::uint32_t>& connections) const {
  std::vector<BagIndexEntry> out;
  for (const auto& e : entries_) {
    if (connections.count(e.connection) != 0) out.push_back(e);
  }
  return out;
}

std::size_t BagFile::MessageCount(std::uint32_t connection) const {
  auto it = message_counts_.find(connection);
  return it == message_counts_.end() ? 0 : it->second;
}

void BagFile::LoadChunk(std::uint32_t index) {
  if (loaded_chunk_ == index) return;
  loaded_chunk_ = -1;
  const Chunk& c = chunks_.at(index);
  const std::string where = At("chunk", c.record_pos);
  if (c.compression == Compression::kNone) {
    chunk_data_.resize(c.data_len);
    ReadBytes(c.data_pos, chunk_data_.data(), c.data_len, "chunk");
  } else {
    std::vector<std::uint8_t> packed(c.data_len);
    ReadBytes(c.data_pos, packed.data(), c.data_len, "chunk");
    chunk_data_.resize(c.size);
    if (c.compression == Compression::kBz2) {
      unsigned int produced = c.size;
      const int rc = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(chunk_data_.data()),
                                                &produced, reinterpret_cast<char*>(packed.data()),
                                                c.data_len, /*small=*/0, /*verbosity=*/0);
      if (rc != BZ_OK || produced != c.size) {
        Fail(where + ": bz2 data does not decompress to the " + std::to_string(c.size) +
             " bytes the chunk claims (bzip2 error " + std::to_string(rc) + ")");
      }
    } else {
      LZ4F_dctx* raw = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
        Fail(where + ": cannot start lz4");
      }
      const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> ctx(
          raw, &LZ4F_freeDecompressionContext);
      std::size_t in_at = 0, out_at = 0;
      std::size_t hint = 1;
      while (hint != 0 && in_at < packed.size()) {
        std::size_t out_n = chunk_data_.size() - out_at;
        std::size_t in_n = packed.size() - in_at;
        hint = LZ4F_decompress(ctx.get(), chunk_data_.data() + out_at, &out_n,
                               packed.data() + in_at, &in_n, nullptr);
        if (LZ4F_isError(hint)) {
          Fail(where + ": lz4 data does not decompress (" + LZ4F_getErrorName(hint) + ")");
        }
        in_at += in_n;
        out_at += out_n;
        if (in_n == 0 && out_n == 0) break;  // no progress: output full or input cut short
      }
      if (hint != 0 || out_at != c.size) {
        Fail(where + ": lz4 data does not decompress to the " + std::to_string(c.size) +
             " bytes the chunk claims (" + std::to_string(out_at) + ")");
      }
    }
  }
  loaded_chunk_ = index;
}

BagFile::Message BagFile::Read(const BagIndexEntry& entry) {
  LoadChunk(entry.chunk);
  const std::string where = "message at offset " + std::to_string(entry.offset) + " of " +
                            At("chunk", chunks_[entry.chunk].record_pos);
  const std::size_t n = chunk_data_.size();
  const std::uint8_t* p = chunk_data_.data();
  std::size_t at = entry.offset;
  if (at > n || n - at < 4) Fail(where + ": cut short");
  const std::uint32_t header_len = U32(p + at);
  at += 4;
  if (header_len > n - at || n - at - header_len < 4) {
    Fail(where + ": header of " + std::to_string(header_len) + " bytes does not fit the chunk");
  }
  const Fields fields = ParseFields(p + at, header_len, where);
  if (FieldU8(fields, "op", where) != kOpMessageData) {
    Fail(where + ": expected a message record (op 2)");
  }
  if (FieldU32(fields, "conn", where) != entry.connection) {
    Fail(where + ": the index says connection " + std::to_string(entry.connection) +
         ", the record another");
  }
  at += header_len;
  const std::uint32_t data_len = U32(p + at);
  at += 4;
  if (data_len > n - at) {
    Fail(where + ": message of " + std::to_string(data_len) + " bytes, " + std::to_string(n - at) +
         " left in the chunk");
  }
  return {p + at, data_len};
}

}  // namespace draco::rosbag::internal
