// A zlib stream (RFC 1950/1951) of literals only: dynamic-Huffman blocks, no LZ77. Any
// inflater reads it (zlib's uncompress, Python's zlib.decompress). It is what zlib's
// Z_HUFFMAN_ONLY produces, at a fraction of zlib's cost: speckle offers order-0 entropy and
// nothing else, so this is the writer's fastest (level 1) encoding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace draco::recording::internal {

// Appends the zlib stream of data[0, size) to out. Deterministic. block_bytes: literals per
// deflate block (each block has its own code, adapting to e.g. near and far ranges).
void HuffmanDeflateAppend(const std::uint8_t* data, std::size_t size,
                          std::vector<std::uint8_t>& out, std::size_t block_bytes = 16384);

}  // namespace draco::recording::internal
