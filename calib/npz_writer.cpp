#include "calib/npz_writer.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstring>
#include <limits>

#include <zlib.h>

namespace camlab::calib {

// .npy and zip are little-endian; the elements are copied as they sit in memory.
static_assert(std::endian::native == std::endian::little,
              "the .npy writer assumes a little-endian host");

namespace {

[[maybe_unused]] size_t element_count(const std::vector<size_t>& shape) {  // for the asserts
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

// Python's repr of a shape tuple: (), (3,), (2, 3).
std::string shape_repr(const std::vector<size_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) s += ",";
  return s + ")";
}

template <typename T>
std::string raw_bytes(const std::vector<T>& values) {
  std::string out(values.size() * sizeof(T), '\0');
  if (!values.empty()) std::memcpy(out.data(), values.data(), out.size());
  return out;
}

// UTF-8 to code points; a malformed sequence yields U+FFFD for its first byte (names come
// from file names, which need not be valid UTF-8).
std::vector<char32_t> code_points(const std::string& utf8) {
  std::vector<char32_t> out;
  const auto* s = reinterpret_cast<const unsigned char*>(utf8.data());
  const size_t n = utf8.size();
  for (size_t i = 0; i < n;) {
    const unsigned char c = s[i];
    const int len = c < 0x80           ? 1
                    : (c >> 5) == 0x6  ? 2
                    : (c >> 4) == 0xE  ? 3
                    : (c >> 3) == 0x1E ? 4
                                       : 0;
    char32_t cp = len == 1 ? c : len == 2 ? c & 0x1F : len == 3 ? c & 0x0F : c & 0x07;
    bool ok = len > 0 && i + len <= n;
    for (int k = 1; ok && k < len; ++k) {
      ok = (s[i + k] & 0xC0) == 0x80;
      cp = (cp << 6) | (s[i + k] & 0x3F);
    }
    // Overlong forms, surrogates and values past U+10FFFF are not characters.
    static constexpr char32_t kMin[5] = {0, 0, 0x80, 0x800, 0x10000};
    ok = ok && cp >= kMin[len] && cp <= 0x10FFFF && (cp < 0xD800 || cp > 0xDFFF);
    out.push_back(ok ? cp : U'\uFFFD');
    i += ok ? len : 1;
  }
  return out;
}

// numpy's fixed-width unicode: `width` UTF-32 code units per string, NUL-padded.
std::string utf32_field(const std::vector<char32_t>& cps, size_t width) {
  std::vector<char32_t> padded(cps);
  padded.resize(width, U'\0');
  return raw_bytes(padded);
}

void put16(std::string* out, uint32_t v) {
  out->push_back(static_cast<char>(v & 0xFF));
  out->push_back(static_cast<char>((v >> 8) & 0xFF));
}

void put32(std::string* out, uint32_t v) {
  put16(out, v & 0xFFFF);
  put16(out, v >> 16);
}

// Raw deflate (no zlib header: zip stores the bare stream). Empty when zlib fails or the
// data do not shrink; the entry is then stored.
std::string deflate_raw(const std::string& data) {
  z_stream z{};
  if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    return {};
  std::string out(deflateBound(&z, static_cast<uLong>(data.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END || out.size() >= data.size()) return {};
  return out;
}

}  // namespace

std::string npy_file(const std::string& descr, const std::vector<size_t>& shape,
                     const std::string& data) {
  std::string header =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape_repr(shape) + ", }";
  // numpy pads the header with spaces and a final newline so that the data start on a
  // 64-byte boundary (magic 6 + version 2 + length 2 + header).
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  put16(&out, static_cast<uint32_t>(header.size()));
  return out + header + data;
}

void NpzWriter::add_float64(const std::string& key, const std::vector<double>& values,
                            const std::vector<size_t>& shape) {
  assert(element_count(shape) == values.size());
  entries_.push_back({key + ".npy", npy_file("<f8", shape, raw_bytes(values))});
}

void NpzWriter::add_int32(const std::string& key, const std::vector<int32_t>& values,
                          const std::vector<size_t>& shape) {
  assert(element_count(shape) == values.size());
  entries_.push_back({key + ".npy", npy_file("<i4", shape, raw_bytes(values))});
}

void NpzWriter::add_bool(const std::string& key, bool value) {
  entries_.push_back({key + ".npy", npy_file("|b1", {}, std::string(1, value ? '\1' : '\0'))});
}

void NpzWriter::add_string(const std::string& key, const std::string& utf8) {
  // np.array('') is '<U1' holding one NUL: a width of at least 1.
  const auto cps = code_points(utf8);
  const size_t width = std::max<size_t>(1, cps.size());
  entries_.push_back(
      {key + ".npy", npy_file("<U" + std::to_string(width), {}, utf32_field(cps, width))});
}

void NpzWriter::add_strings(const std::string& key, const std::vector<std::string>& utf8) {
  std::vector<std::vector<char32_t>> all;
  size_t width = 1;
  for (const auto& s : utf8) {
    all.push_back(code_points(s));
    width = std::max(width, all.back().size());
  }
  std::string data;
  for (const auto& cps : all) data += utf32_field(cps, width);
  entries_.push_back({key + ".npy", npy_file("<U" + std::to_string(width), {utf8.size()}, data)});
}

std::string NpzWriter::archive() const {
  // A plain zip (no zip64: an archive is a few MB at most, far below the 4 GiB limit), one
  // local header + data per entry, then the central directory and its end record. Times
  // are the DOS epoch (1980-01-01 00:00) so equal inputs give equal bytes.
  constexpr uint32_t kDosDate = (1 << 5) | 1, kDosTime = 0;
  std::string out, central;
  for (const auto& e : entries_) {
    const auto crc = static_cast<uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(e.npy.data()), static_cast<uInt>(e.npy.size())));
    const std::string deflated = deflate_raw(e.npy);
    const bool stored = deflated.empty();
    const std::string& body = stored ? e.npy : deflated;
    assert(out.size() + body.size() + e.name.size() + 30 < std::numeric_limits<uint32_t>::max());
    const auto offset = static_cast<uint32_t>(out.size());
    auto fields = [&](std::string* s) {  // shared by the local and the central header
      put16(s, 20);                      // version needed: 2.0 (deflate)
      put16(s, 0);                       // flags
      put16(s, stored ? 0 : 8);          // method: stored or deflate
      put16(s, kDosTime);
      put16(s, kDosDate);
      put32(s, crc);
      put32(s, static_cast<uint32_t>(body.size()));
      put32(s, static_cast<uint32_t>(e.npy.size()));
      put16(s, static_cast<uint32_t>(e.name.size()));
      put16(s, 0);  // extra field length
    };
    put32(&out, 0x04034b50);
    fields(&out);
    out += e.name;
    out += body;

    put32(&central, 0x02014b50);
    put16(&central, 20);  // version made by: 2.0, MS-DOS attributes
    fields(&central);
    put16(&central, 0);  // comment length
    put16(&central, 0);  // disk number
    put16(&central, 0);  // internal attributes
    put32(&central, 0);  // external attributes
    put32(&central, offset);
    central += e.name;
  }
  const auto central_offset = static_cast<uint32_t>(out.size());
  out += central;
  put32(&out, 0x06054b50);
  put16(&out, 0);  // this disk
  put16(&out, 0);  // disk of the central directory
  put16(&out, static_cast<uint32_t>(entries_.size()));
  put16(&out, static_cast<uint32_t>(entries_.size()));
  put32(&out, static_cast<uint32_t>(central.size()));
  put32(&out, central_offset);
  put16(&out, 0);  // comment length
  return out;
}

std::string base85_encode(const std::string& bytes) {
  static constexpr char kAlphabet[] =
      "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz!#$%&()*+-;<=>?@^_`{|}~";
  std::string out;
  out.reserve((bytes.size() + 3) / 4 * 5);
  for (size_t i = 0; i < bytes.size(); i += 4) {
    // A big-endian 32-bit group, zero-padded at the end, as 5 digits in base 85.
    uint32_t v = 0;
    const size_t n = std::min<size_t>(4, bytes.size() - i);
    for (size_t k = 0; k < 4; ++k)
      v = (v << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    char digits[5];
    for (int k = 4; k >= 0; --k) {
      digits[k] = kAlphabet[v % 85];
      v /= 85;
    }
    // Python drops as many characters as bytes of padding it added.
    out.append(digits, 5 - (4 - n));
  }
  return out;
}

}  // namespace camlab::calib
