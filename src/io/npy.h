// NumPy .npy arrays: writing (format version 1.0) and reading (versions 1.0, 2.0 and 3.0).
//
// Supported element types: little-endian float32 ('<f4'), float64 ('<f8'), int32 ('<i4') and
// int64 ('<i8'); C (row-major) order; any number of dimensions, including 0 (a scalar) and
// zero-length dimensions. Written headers are padded so the data starts at a multiple of 64
// bytes, as NumPy does. Files are written atomically (io/atomic_file.h).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace mosyn::io {

enum class NpyDtype { kFloat32, kFloat64, kInt32, kInt64 };

// The NumPy descr string, e.g. "<f4".
const char* to_string(NpyDtype dtype);
// Bytes per element: 4 or 8.
int element_size(NpyDtype dtype);

// An array as stored: raw little-endian element bytes in C order.
struct NpyArray {
  NpyDtype dtype = NpyDtype::kFloat32;
  std::vector<std::int64_t> shape;  // empty for a scalar
  std::string bytes;                // num_elements() * element_size(dtype) bytes

  // Product of shape (1 for a scalar).
  std::int64_t num_elements() const;
  // Elements converted to double / float (int64 beyond 2^53 loses precision).
  std::vector<double> to_float64() const;
  std::vector<float> to_float32() const;
};

// The complete .npy file content for an array. Throws mosyn::Error when a dimension is negative
// or bytes does not match the shape.
std::string format_npy(const NpyArray& array);

// Builds an array from typed data: data holds the product of shape elements, C order.
// Throws mosyn::Error when the sizes disagree or a dimension is negative.
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<float>& data);
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<double>& data);
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<std::int32_t>& data);
NpyArray make_npy(const std::vector<std::int64_t>& shape, const std::vector<std::int64_t>& data);

// Writes an array atomically.
void write_npy(const std::string& path, const NpyArray& array);
// Convenience: make_npy + write_npy.
void write_npy(const std::string& path, const std::vector<std::int64_t>& shape, const std::vector<float>& data);
void write_npy(const std::string& path, const std::vector<std::int64_t>& shape, const std::vector<double>& data);
// Joint positions [T, J] (row-major, index t * J + j) times scale, as float32 [T, J, 3]. Throws
// mosyn::Error when positions does not hold num_frames * num_joints entries.
void write_positions_npy(const std::string& path, int num_frames, int num_joints,
                         const std::vector<Eigen::Vector3d>& positions, double scale = 1.0);

// Parses .npy bytes. Validates the magic string, version, header dictionary ('descr',
// 'fortran_order', 'shape'; keys in any order), the element type (the four above; Fortran order
// is rejected), and that the data size matches the shape exactly. Throws
// mosyn::ParseError(file_name_for_errors, 0, message).
NpyArray parse_npy(const std::string& bytes, const std::string& file_name_for_errors);

// Reads and parses a .npy file. Throws mosyn::Error naming the path.
NpyArray read_npy(const std::string& path);

}  // namespace mosyn::io
