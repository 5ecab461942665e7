// numpy's .npz archives, written without Python: what mrcal 2.2 stores in a .cameramodel's
// 'optimization_inputs' (mrcal/cameramodel.py: np.savez_compressed of the inputs dict,
// then base64.b85encode; read back with np.load(allow_pickle=False)).
//
// Each entry is an .npy file (format 1.0, little-endian, C order), named "<key>.npy" in a
// zip archive whose entries are deflated through zlib. The element types are those np.save
// picks for what mrcal's writer holds:
//   float64 arrays ('<f8') and scalars (0-d '<f8'),
//   int32 index arrays ('<i4'; mrcal's C code reads them as int),
//   bools as 0-d '|b1' (np.save(True)),
//   strings as 0-d '<U<n>' (UTF-32; mrcal stores None as '', a 0-d '<U1' of one NUL),
//   string lists as 1-d '<U<longest>'.
// mrcal's reader turns every 0-d array back into its Python value (arr.item()), so those
// keys arrive as float, bool and str.
//
// Thread-bound: one writer per archive; distinct writers are independent.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace camlab::calib {

class NpzWriter {
 public:
  // `shape` empty: a 0-d array (one value). The product of `shape` must equal
  // values.size() (a bug otherwise: asserted).
  void add_float64(const std::string& key, const std::vector<double>& values,
                   const std::vector<size_t>& shape);
  void add_float64(const std::string& key, double value) { add_float64(key, {value}, {}); }
  void add_int32(const std::string& key, const std::vector<int32_t>& values,
                 const std::vector<size_t>& shape);
  void add_bool(const std::string& key, bool value);
  // UTF-8 in, stored as numpy's UTF-32 '<U' (invalid UTF-8 bytes become U+FFFD).
  void add_string(const std::string& key, const std::string& utf8);
  void add_strings(const std::string& key, const std::vector<std::string>& utf8);

  // The .npz bytes. Entries keep the order they were added in.
  std::string archive() const;

 private:
  struct Entry {
    std::string name;  // "<key>.npy"
    std::string npy;   // the whole .npy file
  };
  std::vector<Entry> entries_;
};

// The .npy bytes of one array: the header for `descr` (numpy's type string, e.g. "<f8")
// and `shape`, then `data` (the raw elements, C order).
std::string npy_file(const std::string& descr, const std::vector<size_t>& shape,
                     const std::string& data);

// Python's base64.b85encode (RFC 1924 alphabet; a short last group is zero-padded and
// its padding characters dropped), which mrcal uses for the .npz in a .cameramodel. Its
// alphabet has no quote and no backslash, so the result is a valid Python b'...' body.
std::string base85_encode(const std::string& bytes);

}  // namespace camlab::calib
