#include "io/deflate.hpp"

#include <libdeflate.h>

#include <algorithm>
#include <array>
#include <cstring>

namespace terrabake::io {
namespace {

// RFC 1951's alphabets and limits.
constexpr int kLiteralLengthSymbols = 286;  // 0-255 bytes, 256 end of block, 257-285 match lengths
constexpr int kDistanceSymbols = 30;
constexpr int kCodeLengthSymbols = 19;
constexpr int kEndOfBlock = 256;
constexpr int kMaxCodeBits = 15;
constexpr int kMaxCodeLengthBits = 7;
constexpr int kMinMatch = 3;
constexpr int kMaxMatch = 258;

// Runs shorter than this are coded byte by byte: on Paeth-filtered normal
// maps a short run of zeros costs fewer bits as literals, whose code for
// zero is one or two bits long, than as a length and a distance (measured
// on the benchmark pyramid's and the sample layer's tiles,
// docs/performance.md, "PNG encoding").
constexpr std::size_t kMinRun = 8;  // the bytes of one 64-bit comparison

// Bytes a block codes with one set of Huffman codes: large enough that the
// codes' description is a small share of it, small enough that the codes
// follow the image as it changes from top to bottom.
constexpr std::size_t kBlockBytes = 32 * 1024;

// Match lengths: the first length of each symbol from 257 on, and its extra bits.
constexpr std::array<int, 29> kLengthBase = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                             31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<int, 29> kLengthExtraBits = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                                  2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
// The order in which a block header gives the code-length code's lengths.
constexpr std::array<int, kCodeLengthSymbols> kCodeLengthOrder = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                                                  11, 4,  12, 3, 13, 2, 14, 1, 15};

// The index into kLengthBase of every match length.
struct LengthSymbols {
  std::array<std::uint8_t, kMaxMatch + 1> index{};
  LengthSymbols() {
    int s = 0;
    for (int length = kMinMatch; length <= kMaxMatch; ++length) {
      while (s + 1 < int(kLengthBase.size()) && kLengthBase[std::size_t(s) + 1] <= length) ++s;
      index[std::size_t(length)] = std::uint8_t(s);
    }
  }
};
const LengthSymbols kLengthSymbols;

// Bits written least significant first, as deflate packs them: put() adds
// bits to a 64-bit buffer, flush() writes out its whole bytes without a
// branch and leaves at most 7, so up to 57 bits may be put between flushes.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "flush() stores the buffer's bytes as they lie");
class BitWriter {
 public:
  explicit BitWriter(std::vector<std::uint8_t>& out) : m_out(&out), m_at(out.data()) {}

  // Room for `bytes` more whole bytes, and for flush()'s eight-byte stores.
  void reserve(std::size_t bytes) {
    const std::size_t written = std::size_t(m_at - m_out->data());
    if (m_out->size() < written + bytes + 16) {
      m_out->resize(std::max(m_out->size() * 2, written + bytes + 16));
      m_at = m_out->data() + written;
    }
  }

  void put(std::uint64_t value, int count) {
    m_bits |= value << m_count;
    m_count += count;
  }

  void flush() {
    std::memcpy(m_at, &m_bits, sizeof m_bits);
    const int whole = m_count & ~7;
    m_at += whole / 8;
    m_bits = whole == 64 ? 0 : m_bits >> whole;
    m_count -= whole;
  }

  // Pads to a whole byte and returns the bytes written.
  std::size_t finish() {
    m_count = (m_count + 7) & ~7;
    flush();
    return std::size_t(m_at - m_out->data());
  }

 private:
  std::vector<std::uint8_t>* m_out;
  std::uint8_t* m_at;  // the next whole byte
  std::uint64_t m_bits = 0;
  int m_count = 0;
};

// A canonical Huffman code: each symbol's length and its code, bit-reversed
// for a least-significant-first writer.
struct HuffmanCode {
  std::vector<std::uint8_t> length;
  std::vector<std::uint16_t> code;
};

// Lengths no longer than max_bits for the symbols counted in `frequency`,
// giving a complete code over at least two symbols (inflaters reject a
// code with a single symbol of one bit); unused symbols get 0.
std::vector<std::uint8_t> huffmanLengths(std::vector<std::uint32_t> frequency, int max_bits) {
  const int n = int(frequency.size());
  std::vector<int> used;
  for (int s = 0; s < n; ++s) {
    if (frequency[std::size_t(s)] > 0) used.push_back(s);
  }
  for (int s = 0; used.size() < 2; ++s) {
    if (frequency[std::size_t(s)] == 0) {
      frequency[std::size_t(s)] = 1;
      used.push_back(s);
    }
  }
  std::sort(used.begin(), used.end(), [&](int a, int b) {
    return frequency[std::size_t(a)] != frequency[std::size_t(b)]
               ? frequency[std::size_t(a)] < frequency[std::size_t(b)]
               : a < b;
  });

  // Huffman's tree by two queues: the leaves in rising frequency, then the
  // joined nodes, which arise in rising weight too.
  const int leaves = int(used.size());
  std::vector<std::uint64_t> weight(std::size_t(2 * leaves - 1));
  std::vector<int> parent(weight.size(), -1);
  for (int k = 0; k < leaves; ++k) weight[std::size_t(k)] = frequency[std::size_t(used[std::size_t(k)])];
  int next_leaf = 0, next_joined = leaves;
  const auto lightest = [&](int joined_end) {
    if (next_leaf < leaves &&
        (next_joined >= joined_end || weight[std::size_t(next_leaf)] <= weight[std::size_t(next_joined)])) {
      return next_leaf++;
    }
    return next_joined++;
  };
  for (int joined = leaves; joined < 2 * leaves - 1; ++joined) {
    const int a = lightest(joined), b = lightest(joined);
    weight[std::size_t(joined)] = weight[std::size_t(a)] + weight[std::size_t(b)];
    parent[std::size_t(a)] = parent[std::size_t(b)] = joined;
  }
  // Depths from the root (the last node) down.
  std::vector<int> depth(weight.size(), 0);
  for (int k = 2 * leaves - 3; k >= 0; --k) depth[std::size_t(k)] = depth[std::size_t(parent[std::size_t(k)])] + 1;

  // Too-long codes are cut to max_bits, then codes are lengthened, one
  // leaf at a time, until the lengths fit a binary tree again (Kraft's sum
  // back to one).
  std::vector<int> count(std::size_t(max_bits) + 1, 0);
  for (int k = 0; k < leaves; ++k) ++count[std::size_t(std::min(depth[std::size_t(k)], max_bits))];
  std::uint64_t kraft = 0;
  for (int bits = 1; bits <= max_bits; ++bits) kraft += std::uint64_t(count[std::size_t(bits)]) << (max_bits - bits);
  while (kraft > (std::uint64_t(1) << max_bits)) {
    --count[std::size_t(max_bits)];
    for (int bits = max_bits - 1; bits > 0; --bits) {
      if (count[std::size_t(bits)] > 0) {
        --count[std::size_t(bits)];
        count[std::size_t(bits) + 1] += 2;
        break;
      }
    }
    --kraft;
  }
  // The longest codes to the rarest symbols.
  std::vector<std::uint8_t> length(std::size_t(n), 0);
  int k = 0;
  for (int bits = max_bits; bits > 0; --bits) {
    for (int c = 0; c < count[std::size_t(bits)]; ++c) length[std::size_t(used[std::size_t(k++)])] = std::uint8_t(bits);
  }
  return length;
}

// RFC 1951 3.2.2: codes of one length are consecutive, in symbol order.
HuffmanCode canonicalCode(std::vector<std::uint8_t> length) {
  std::array<int, kMaxCodeBits + 2> first{};
  for (const std::uint8_t bits : length) ++first[bits];
  first[0] = 0;
  int code = 0;
  std::array<int, kMaxCodeBits + 2> next{};
  for (int bits = 1; bits <= kMaxCodeBits; ++bits) {
    code = (code + first[std::size_t(bits) - 1]) << 1;
    next[std::size_t(bits)] = code;
  }
  HuffmanCode out{std::move(length), {}};
  out.code.resize(out.length.size(), 0);
  for (std::size_t s = 0; s < out.length.size(); ++s) {
    const int bits = out.length[s];
    if (bits == 0) continue;
    int value = next[std::size_t(bits)]++, reversed = 0;
    for (int b = 0; b < bits; ++b, value >>= 1) reversed = (reversed << 1) | (value & 1);
    out.code[s] = std::uint16_t(reversed);
  }
  return out;
}

HuffmanCode fittedCode(const std::vector<std::uint32_t>& frequency, int max_bits) {
  return canonicalCode(huffmanLengths(frequency, max_bits));
}

// A block's content: stretches of bytes coded one by one, each followed by
// a run repeating the byte before the run (run 0: none, at the block's end).
struct Stretch {
  std::size_t first;
  std::size_t count;
  std::size_t run;
};

// The code-length sequence of a block header, run-length coded with
// symbols 16 (repeat the last length 3-6 times), 17 (3-10 zeros) and 18
// (11-138 zeros); each entry a symbol and its extra bits' value.
struct CodeLengthToken {
  std::uint8_t symbol;
  std::uint8_t extra;
};
std::vector<CodeLengthToken> codeLengthTokens(const std::vector<std::uint8_t>& lengths) {
  std::vector<CodeLengthToken> out;
  for (std::size_t k = 0; k < lengths.size();) {
    const std::uint8_t value = lengths[k];
    std::size_t run = 1;
    while (k + run < lengths.size() && lengths[k + run] == value) ++run;
    k += run;
    if (value == 0) {
      for (std::size_t n; run >= 11; run -= n) {
        n = std::min<std::size_t>(run, 138);
        out.push_back({18, std::uint8_t(n - 11)});
      }
      if (run >= 3) {
        out.push_back({17, std::uint8_t(run - 3)});
        run = 0;
      }
    } else {
      out.push_back({value, 0});
      --run;
      for (std::size_t n; run >= 3; run -= n) {
        n = std::min<std::size_t>(run, 6);
        out.push_back({16, std::uint8_t(n - 3)});
      }
    }
    for (; run > 0; --run) out.push_back({value, 0});
  }
  return out;
}

void writeBlock(BitWriter& writer, const std::uint8_t* data, const std::vector<Stretch>& stretches, bool last) {
  // A copy of its own, whose address nothing takes: the compiler keeps it in
  // registers, where the writer's bytes, which may alias anything, would
  // otherwise make it store and load it again at every code.
  BitWriter out = writer;
  // Bytes are counted in four tables, a byte in each in turn: in a stretch
  // of one byte value each count would otherwise wait for the one before.
  std::array<std::array<std::uint32_t, 256>, 4> byte_counts{};
  std::vector<std::uint32_t> literal_frequency(kLiteralLengthSymbols, 0), distance_frequency(kDistanceSymbols, 0);
  std::size_t bytes = 0;
  for (const Stretch& stretch : stretches) {
    const std::uint8_t* p = data + stretch.first;
    std::size_t k = 0;
    for (; k + 4 <= stretch.count; k += 4) {
      ++byte_counts[0][p[k]], ++byte_counts[1][p[k + 1]], ++byte_counts[2][p[k + 2]], ++byte_counts[3][p[k + 3]];
    }
    for (; k < stretch.count; ++k) ++byte_counts[0][p[k]];
    bytes += stretch.count;
    if (stretch.run > 0) {
      ++literal_frequency[257 + kLengthSymbols.index[stretch.run]];
      ++distance_frequency[0];  // distance 1
    }
  }
  for (std::size_t b = 0; b < 256; ++b) {
    literal_frequency[b] = byte_counts[0][b] + byte_counts[1][b] + byte_counts[2][b] + byte_counts[3][b];
  }
  literal_frequency[kEndOfBlock] = 1;
  const HuffmanCode literals = fittedCode(literal_frequency, kMaxCodeBits);
  const HuffmanCode distances = fittedCode(distance_frequency, kMaxCodeBits);

  std::size_t literal_count = kLiteralLengthSymbols, distance_count = kDistanceSymbols;
  while (literal_count > 257 && literals.length[literal_count - 1] == 0) --literal_count;
  while (distance_count > 1 && distances.length[distance_count - 1] == 0) --distance_count;
  std::vector<std::uint8_t> lengths(literals.length.begin(), literals.length.begin() + std::ptrdiff_t(literal_count));
  lengths.insert(lengths.end(), distances.length.begin(), distances.length.begin() + std::ptrdiff_t(distance_count));
  const std::vector<CodeLengthToken> header = codeLengthTokens(lengths);
  std::vector<std::uint32_t> header_frequency(kCodeLengthSymbols, 0);
  for (const CodeLengthToken& t : header) ++header_frequency[t.symbol];
  const HuffmanCode header_code = fittedCode(header_frequency, kMaxCodeLengthBits);
  std::size_t header_count = kCodeLengthSymbols;
  while (header_count > 4 && header_code.length[std::size_t(kCodeLengthOrder[header_count - 1])] == 0) --header_count;

  // A byte takes at most 15 bits, a run 15 + 5 + 15; the header less than 400 bytes.
  out.reserve(2 * bytes + 5 * stretches.size() + 512);
  out.put(last ? 1 : 0, 1);
  out.put(2, 2);  // dynamic Huffman codes
  out.put(literal_count - 257, 5);
  out.put(distance_count - 1, 5);
  out.put(header_count - 4, 4);
  out.flush();
  for (std::size_t k = 0; k < header_count; ++k) {
    out.put(header_code.length[std::size_t(kCodeLengthOrder[k])], 3);
    out.flush();
  }
  for (const CodeLengthToken& t : header) {
    constexpr std::array<int, kCodeLengthSymbols> kExtraBits = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                                                0, 0, 0, 0, 0, 0, 2, 3, 7};
    out.put(header_code.code[t.symbol], header_code.length[t.symbol]);
    out.put(t.extra, kExtraBits[t.symbol]);
    out.flush();
  }
  // Each byte's code and its length in one entry: one load a byte.
  std::array<std::uint32_t, 256> byte_code{};
  for (std::size_t b = 0; b < 256; ++b) byte_code[b] = literals.code[b] | std::uint32_t(literals.length[b]) << 16;
  const auto putByte = [&](std::uint8_t byte) {
    const std::uint32_t entry = byte_code[byte];
    out.put(entry & 0xffff, int(entry >> 16));
  };
  for (const Stretch& stretch : stretches) {
    // Locals: the writer's stores might otherwise change them, for all the compiler knows.
    const std::uint8_t* const p = data + stretch.first;
    const std::size_t count = stretch.count;
    std::size_t k = 0;
    // Three bytes' codes (45 bits at most) fit beside the seven a flush may leave.
    for (; k + 3 <= count; k += 3) {
      putByte(p[k]);
      putByte(p[k + 1]);
      putByte(p[k + 2]);
      out.flush();
    }
    for (; k < count; ++k) {
      putByte(p[k]);
      out.flush();
    }
    if (stretch.run > 0) {
      const std::size_t s = kLengthSymbols.index[stretch.run];
      out.put(literals.code[257 + s], literals.length[257 + s]);
      out.put(std::uint32_t(stretch.run - std::size_t(kLengthBase[s])), kLengthExtraBits[s]);
      out.put(distances.code[0], distances.length[0]);
      out.flush();
    }
  }
  out.put(literals.code[kEndOfBlock], literals.length[kEndOfBlock]);
  out.flush();
  writer = out;
}

// Whether a run long enough to code starts at `at` (> 0): most bytes start
// none, and one comparison of its kMinRun bytes at once tells.
bool startsRun(const std::uint8_t* data, std::size_t at, std::size_t size) {
  if (at + kMinRun > size) return false;
  std::uint64_t next;
  std::memcpy(&next, data + at, sizeof next);
  return next == data[at - 1] * 0x0101010101010101ull;
}

// The number of bytes from `at` on, up to `most`, that repeat the byte before `at`.
std::size_t runAt(const std::uint8_t* data, std::size_t at, std::size_t most) {
  std::size_t run = 0;
  while (run < most && data[at + run] == data[at - 1]) ++run;
  return run;
}

}  // namespace

std::vector<std::uint8_t> zlibCompress(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> out(size / 2 + 64);
  BitWriter bits(out);
  // CMF: deflate with a 32 KiB window; FLG: fastest compression, no
  // dictionary, and the check bits that make CMF * 256 + FLG a multiple of 31.
  bits.put(0x78, 8);
  bits.put(0x01, 8);
  bits.flush();

  std::vector<Stretch> stretches;
  std::size_t k = 0;
  do {
    // A run may reach past the block's end; the next block starts where it ends.
    const std::size_t block_end = std::min(size, k + kBlockBytes);
    stretches.clear();
    // The first byte has none before it to repeat.
    std::size_t first = k;
    if (k == 0 && size > 0) ++k;
    while (k < block_end) {
      // A run from any of the next kMinRun bytes would take in the last of
      // them and the one before it: where those differ, none starts there.
      if (k + kMinRun <= size && data[k + kMinRun - 1] != data[k + kMinRun - 2]) {
        k = std::min(k + kMinRun, block_end);
        continue;
      }
      if (startsRun(data, k, size)) {
        const std::size_t run = runAt(data, k, std::min<std::size_t>(kMaxMatch, size - k));
        stretches.push_back({first, k - first, run});
        k += run;
        first = k;
      } else {
        ++k;
      }
    }
    if (k > first || stretches.empty()) stretches.push_back({first, k - first, 0});
    writeBlock(bits, data, stretches, k >= size);
  } while (k < size);
  std::size_t end = bits.finish();
  const std::uint32_t adler = libdeflate_adler32(1, data, size);
  out.resize(end + 4);
  for (int b = 3; b >= 0; --b) out[end++] = std::uint8_t(adler >> (8 * b));
  return out;
}

}  // namespace terrabake::io
