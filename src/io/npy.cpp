#include "io/npy.h"

#include <cstring>
#include <string_view>

#include "core/error.h"
#include "io/atomic_file.h"

// .npy stores little-endian data and we copy bytes as they are.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "mosyn's .npy support assumes a little-endian host");

namespace mosyn::io {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicSize = 6;
constexpr int kMaxDims = 32;

// Product of dimensions, or -1 on a negative dimension or overflow past int64.
std::int64_t checked_count(const std::vector<std::int64_t>& shape) {
  std::int64_t n = 1;
  for (std::int64_t d : shape) {
    if (d < 0) return -1;
    if (__builtin_mul_overflow(n, d, &n)) return -1;
  }
  return n;
}

template <typename T>
NpyArray make_typed(NpyDtype dtype, const std::vector<std::int64_t>& shape, const std::vector<T>& data) {
  const std::int64_t n = checked_count(shape);
  if (n < 0) throw Error("npy: invalid shape (a negative dimension or too many elements)");
  if (static_cast<std::uint64_t>(n) != data.size())
    throw Error("npy: shape holds " + std::to_string(n) + " elements but " + std::to_string(data.size()) + " were given");
  NpyArray a;
  a.dtype = dtype;
  a.shape = shape;
  a.bytes.assign(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(T));
  return a;
}

template <typename Out>
std::vector<Out> convert(const NpyArray& a) {
  const size_t n = a.bytes.size() / static_cast<size_t>(element_size(a.dtype));
  std::vector<Out> out(n);
  const char* p = a.bytes.data();
  for (size_t i = 0; i < n; ++i) {
    switch (a.dtype) {
      case NpyDtype::kFloat32: { float v; std::memcpy(&v, p + 4 * i, 4); out[i] = static_cast<Out>(v); break; }
      case NpyDtype::kFloat64: { double v; std::memcpy(&v, p + 8 * i, 8); out[i] = static_cast<Out>(v); break; }
      case NpyDtype::kInt32: { std::int32_t v; std::memcpy(&v, p + 4 * i, 4); out[i] = static_cast<Out>(v); break; }
      case NpyDtype::kInt64: { std::int64_t v; std::memcpy(&v, p + 8 * i, 8); out[i] = static_cast<Out>(v); break; }
    }
  }
  return out;
}

// A parser for the header dictionary, a Python literal such as
// {'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }
class HeaderParser {
 public:
  HeaderParser(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  NpyArray parse() {
    NpyArray a;
    bool has_descr = false, has_order = false, has_shape = false;
    skip_space();
    expect('{');
    for (;;) {
      skip_space();
      if (peek() == '}') break;
      const std::string key = parse_string();
      skip_space();
      expect(':');
      skip_space();
      if (key == "descr") {
        const std::string descr = parse_string();
        if (descr == "<f4") a.dtype = NpyDtype::kFloat32;
        else if (descr == "<f8") a.dtype = NpyDtype::kFloat64;
        else if (descr == "<i4") a.dtype = NpyDtype::kInt32;
        else if (descr == "<i8") a.dtype = NpyDtype::kInt64;
        else fail("unsupported dtype '" + descr.substr(0, 40) + "' (supported: <f4, <f8, <i4, <i8)");
        has_descr = true;
      } else if (key == "fortran_order") {
        if (consume_word("False")) {
        } else if (consume_word("True")) {
          fail("Fortran-order arrays are not supported");
        } else {
          fail("expected True or False for 'fortran_order'");
        }
        has_order = true;
      } else if (key == "shape") {
        a.shape = parse_shape();
        has_shape = true;
      } else {
        fail("unexpected key '" + key.substr(0, 40) + "' in the header");
      }
      skip_space();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      if (peek() != '}') fail("expected ',' or '}' in the header dictionary");
    }
    ++pos_;
    skip_space();
    if (pos_ != text_.size()) fail("unexpected text after the header dictionary");
    if (!has_descr || !has_order || !has_shape) fail("the header lacks 'descr', 'fortran_order' or 'shape'");
    return a;
  }

 private:
  [[noreturn]] void fail(const std::string& message) const { throw ParseError(file_, 0, "invalid .npy header: " + message); }
  char peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  void skip_space() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n' || text_[pos_] == '\t' || text_[pos_] == '\r')) ++pos_;
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  bool consume_word(std::string_view word) {
    if (text_.substr(pos_, word.size()) != word) return false;
    pos_ += word.size();
    return true;
  }
  std::string parse_string() {
    const char q = peek();
    if (q != '\'' && q != '"') fail("expected a quoted string");
    const size_t close = text_.find(q, pos_ + 1);
    if (close == std::string_view::npos) fail("unterminated string");
    std::string s(text_.substr(pos_ + 1, close - pos_ - 1));
    pos_ = close + 1;
    return s;
  }
  std::vector<std::int64_t> parse_shape() {
    std::vector<std::int64_t> shape;
    expect('(');
    for (;;) {
      skip_space();
      if (peek() == ')') break;
      if (peek() < '0' || peek() > '9') fail("expected a non-negative integer in 'shape'");
      std::int64_t d = 0;
      while (peek() >= '0' && peek() <= '9') {
        if (__builtin_mul_overflow(d, 10, &d) || __builtin_add_overflow(d, peek() - '0', &d)) fail("dimension too large");
        ++pos_;
      }
      if (peek() == 'L') ++pos_;  // Python 2 long suffix
      shape.push_back(d);
      if (shape.size() > static_cast<size_t>(kMaxDims)) fail("more than 32 dimensions");
      skip_space();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      if (peek() != ')') fail("expected ',' or ')' in 'shape'");
    }
    ++pos_;
    return shape;
  }

  std::string_view text_;
  const std::string& file_;
  size_t pos_ = 0;
};

std::string format_shape(const std::vector<std::int64_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) s += ", ";
    s += std::to_string(shape[i]);
  }
  if (shape.size() == 1) s += ",";
  return s + ")";
}

}  // namespace

const char* to_string(NpyDtype dtype) {
  switch (dtype) {
    case NpyDtype::kFloat32: return "<f4";
    case NpyDtype::kFloat64: return "<f8";
    case NpyDtype::kInt32: return "<i4";
    case NpyDtype::kInt64: return "<i8";
  }
  return "?";
}

int element_size(NpyDtype dtype) { return (dtype == NpyDtype::kFloat32 || dtype == NpyDtype::kInt32) ? 4 : 8; }

std::int64_t NpyArray::num_elements() const { return checked_count(shape); }
std::vector<double> NpyArray::to_float64() const { return convert<double>(*this); }
std::vector<float> NpyArray::to_float32() const { return convert<float>(*this); }

NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<float>& data) {
  return make_typed(NpyDtype::kFloat32, shape, data);
}
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<double>& data) {
  return make_typed(NpyDtype::kFloat64, shape, data);
}
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<std::int32_t>& data) {
  return make_typed(NpyDtype::kInt32, shape, data);
}
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<std::int64_t>& data) {
  return make_typed(NpyDtype::kInt64, shape, data);
}

std::string format_npy(const NpyArray& array) {
  const std::int64_t n = checked_count(array.shape);
  if (n < 0) throw Error("npy: invalid shape (a negative dimension or too many elements)");
  if (static_cast<std::uint64_t>(n) * static_cast<std::uint64_t>(element_size(array.dtype)) != array.bytes.size())
    throw Error("npy: " + std::to_string(array.bytes.size()) + " data bytes do not match shape " + format_shape(array.shape));
  std::string header = std::string("{'descr': '") + to_string(array.dtype) +
                       "', 'fortran_order': False, 'shape': " + format_shape(array.shape) + ", }";
  // Pad with spaces and a final newline so the data starts at a multiple of 64 bytes.
  const size_t prefix = kMagicSize + 2 + 2;
  const size_t total = (prefix + header.size() + 1 + 63) / 64 * 64;
  header.append(total - prefix - header.size() - 1, ' ');
  header += '\n';
  if (header.size() > 65535) throw Error("npy: header too long (too many dimensions)");
  std::string out(kMagic, kMagicSize);
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  out += array.bytes;
  return out;
}

void write_npy(const std::string& path, const NpyArray& array) { write_file_atomically(path, format_npy(array)); }
void write_npy(const std::string& path, const std::vector<std::int64_t>& shape, const std::vector<float>& data) {
  write_npy(path, make_npy(shape, data));
}
void write_npy(const std::string& path, const std::vector<std::int64_t>& shape, const std::vector<double>& data) {
  write_npy(path, make_npy(shape, data));
}

void write_positions_npy(const std::string& path, int num_frames, int num_joints,
                         const std::vector<Eigen::Vector3d>& positions, double scale) {
  if (num_frames < 0 || num_joints < 0 ||
      positions.size() != static_cast<size_t>(num_frames) * static_cast<size_t>(num_joints))
    throw Error(path + ": " + std::to_string(positions.size()) + " joint positions for " + std::to_string(num_frames) +
                " frames of " + std::to_string(num_joints) + " joints");
  std::vector<float> values;
  values.reserve(positions.size() * 3);
  for (const auto& p : positions)
    for (int k = 0; k < 3; ++k) values.push_back(static_cast<float>(p[k] * scale));
  write_npy(path, {num_frames, num_joints, 3}, values);
}

NpyArray parse_npy(const std::string& bytes, const std::string& file_name_for_errors) {
  const std::string& file = file_name_for_errors;
  if (bytes.size() < kMagicSize + 2 || bytes.compare(0, kMagicSize, kMagic, kMagicSize) != 0)
    throw ParseError(file, 0, "not a .npy file (missing the \\x93NUMPY magic string)");
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t length_size = 0;
  if (major == 1) length_size = 2;
  else if (major == 2 || major == 3) length_size = 4;
  else throw ParseError(file, 0, "unsupported .npy format version " + std::to_string(major));
  const size_t prefix = kMagicSize + 2 + length_size;
  if (bytes.size() < prefix) throw ParseError(file, 0, "truncated .npy header");
  std::uint64_t header_size = 0;
  for (size_t i = 0; i < length_size; ++i)
    header_size |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes[kMagicSize + 2 + i])) << (8 * i);
  if (header_size > bytes.size() - prefix)
    throw ParseError(file, 0, "truncated .npy header (" + std::to_string(header_size) + " bytes announced, " +
                                  std::to_string(bytes.size() - prefix) + " present)");
  NpyArray a = HeaderParser(std::string_view(bytes).substr(prefix, header_size), file).parse();
  const std::int64_t n = checked_count(a.shape);
  std::uint64_t data_size = 0;
  if (n < 0 || __builtin_mul_overflow(static_cast<std::uint64_t>(n), static_cast<std::uint64_t>(element_size(a.dtype)), &data_size))
    throw ParseError(file, 0, "invalid .npy shape " + format_shape(a.shape));
  const std::uint64_t present = bytes.size() - prefix - header_size;
  if (present != data_size)
    throw ParseError(file, 0, "shape " + format_shape(a.shape) + " of " + to_string(a.dtype) + " needs " +
                                  std::to_string(data_size) + " data bytes, the file has " + std::to_string(present));
  a.bytes = bytes.substr(prefix + header_size);
  return a;
}

NpyArray read_npy(const std::string& path) { return parse_npy(read_file(path), path); }

}  // namespace mosyn::io
