#include "io/npy.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;

using testing::make_temp_dir;

// A header exactly as NumPy writes it, padded to 64 bytes, followed by data bytes.
std::string npy_bytes(const std::string& dict, const std::string& data, char major = 1) {
  std::string header = dict;
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string out = std::string("\x93NUMPY", 6) + major + '\0';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

void expect_npy_error(const std::string& bytes, const std::string& contains) {
  try {
    parse_npy(bytes, "bad.npy");
    ADD_FAILURE() << "no error; expected " << contains;
  } catch (const ParseError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("bad.npy: ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find(contains), std::string::npos) << e.what();
  }
}

TEST(Npy, Float32RoundTripWithShape) {
  const fs::path dir = make_temp_dir("npy_f32");
  std::vector<float> data(2 * 3 * 4);
  for (size_t i = 0; i < data.size(); ++i) data[i] = 0.5f * static_cast<float>(i) - 3.25f;
  const std::string path = (dir / "a.npy").string();
  write_npy(path, {2, 3, 4}, data);
  const std::string bytes = read_file(path);
  EXPECT_EQ(bytes.substr(0, 6), std::string("\x93NUMPY", 6));
  EXPECT_EQ((bytes.size() - data.size() * 4) % 64, 0u);  // data aligned to 64 bytes
  EXPECT_NE(bytes.find("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4), }"), std::string::npos);
  const NpyArray a = read_npy(path);
  EXPECT_EQ(a.dtype, NpyDtype::kFloat32);
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3, 4}));
  EXPECT_EQ(a.num_elements(), 24);
  EXPECT_EQ(a.to_float32(), data);
  EXPECT_EQ(a.to_float64()[5], static_cast<double>(data[5]));
  fs::remove_all(dir);
}

TEST(Npy, Float64AndIntegerRoundTrips) {
  const std::vector<double> d = {1.0 / 3, -2e300, 5e-310, 0.0};
  NpyArray a = parse_npy(format_npy(make_npy({4}, d)), "d.npy");
  EXPECT_EQ(a.dtype, NpyDtype::kFloat64);
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{4}));
  EXPECT_EQ(a.to_float64(), d);
  EXPECT_NE(format_npy(make_npy({4}, d)).find("'shape': (4,)"), std::string::npos);

  const std::vector<std::int32_t> i32 = {1, -2, 2147483647, -2147483647 - 1, 0, 7};
  a = parse_npy(format_npy(make_npy({3, 2}, i32)), "i.npy");
  EXPECT_EQ(a.dtype, NpyDtype::kInt32);
  EXPECT_EQ(a.to_float64()[2], 2147483647.0);
  const std::vector<std::int64_t> i64 = {-5, 1LL << 40};
  a = parse_npy(format_npy(make_npy({2, 1}, i64)), "l.npy");
  EXPECT_EQ(a.dtype, NpyDtype::kInt64);
  EXPECT_EQ(a.to_float64()[1], static_cast<double>(1LL << 40));
}

TEST(Npy, ScalarsAndEmptyArrays) {
  NpyArray a = parse_npy(format_npy(make_npy({}, std::vector<double>{42.0})), "s.npy");
  EXPECT_TRUE(a.shape.empty());
  EXPECT_EQ(a.to_float64(), std::vector<double>{42.0});
  a = parse_npy(format_npy(make_npy({0, 5}, std::vector<float>{})), "e.npy");
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{0, 5}));
  EXPECT_EQ(a.num_elements(), 0);
}

TEST(Npy, ReadsHeadersWrittenByNumpyVariants) {
  std::string data(8, '\0');
  const double v = 2.5;
  std::memcpy(&data[0], &v, 8);
  // Keys in another order, double quotes, no trailing comma, version 2.0.
  NpyArray a = parse_npy(npy_bytes("{\"shape\": (1, 1), \"descr\": \"<f8\", \"fortran_order\": False}", data), "v.npy");
  EXPECT_EQ(a.to_float64(), std::vector<double>{2.5});
  std::string v2 = npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (1,), }", data);
  // Rewrite as version 2.0 with a 4-byte header length.
  const std::string header = v2.substr(10, v2.size() - 10 - 8);
  std::string bytes = std::string("\x93NUMPY", 6) + '\x02' + '\0';
  const uint32_t n = static_cast<uint32_t>(header.size());
  for (int i = 0; i < 4; ++i) bytes += static_cast<char>((n >> (8 * i)) & 0xff);
  bytes += header + data;
  EXPECT_EQ(parse_npy(bytes, "v2.npy").to_float64(), std::vector<double>{2.5});
}

TEST(Npy, RejectsMalformedFiles) {
  const std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }";
  const std::string data(8, '\0');
  ASSERT_NO_THROW(parse_npy(npy_bytes(dict, data), "ok.npy"));
  expect_npy_error("", "magic");
  expect_npy_error("PK\x03\x04 not numpy", "magic");
  expect_npy_error(npy_bytes(dict, data, 9), "version 9");
  expect_npy_error(npy_bytes(dict, data).substr(0, 9), "truncated");
  expect_npy_error(npy_bytes(dict, data).substr(0, 40), "truncated");
  expect_npy_error(npy_bytes(dict, data.substr(0, 7)), "needs 8 data bytes, the file has 7");
  expect_npy_error(npy_bytes(dict, data + "x"), "needs 8 data bytes, the file has 9");
  expect_npy_error(npy_bytes("{'descr': '>f4', 'fortran_order': False, 'shape': (2,), }", data), "unsupported dtype '>f4'");
  expect_npy_error(npy_bytes("{'descr': '<c16', 'fortran_order': False, 'shape': (2,), }", data), "unsupported dtype");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': True, 'shape': (2,), }", data), "Fortran");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'shape': (2,), }", data), "lacks");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'extra': 1}", data), "unexpected key");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (-2,), }", data), "non-negative");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2, x), }", data), "non-negative");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (99999999999999999999,), }", data), "too large");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (4294967296, 4294967296, 4294967296), }", data),
                   "invalid .npy shape");
  expect_npy_error(npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2,)", data), "expected ',' or '}'");
  expect_npy_error(npy_bytes("['descr']", data), "expected '{'");
  expect_npy_error(npy_bytes("{'descr: '<f4'}", data), "");
  // Every truncation of a valid file is rejected cleanly.
  const std::string valid = npy_bytes(dict, data);
  for (size_t n = 0; n < valid.size(); ++n) EXPECT_THROW(parse_npy(valid.substr(0, n), "cut.npy"), ParseError) << n;
}

TEST(Npy, ReadNpyNamesThePath) {
  try {
    read_npy("/nonexistent_mosyn/x.npy");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_mosyn/x.npy"), std::string::npos);
  }
}

TEST(Npy, MakeRejectsMismatchedSizes) {
  EXPECT_THROW(make_npy({2, 3}, std::vector<float>(5)), Error);
  EXPECT_THROW(make_npy({-1}, std::vector<float>{}), Error);
  NpyArray a = make_npy({2}, std::vector<float>{1, 2});
  a.bytes.pop_back();
  EXPECT_THROW(format_npy(a), Error);
}

TEST(Npy, PositionsAreFloat32FramesJointsXyzScaled) {
  const fs::path dir = make_temp_dir("npy_positions");
  const std::string path = (dir / "p.npy").string();
  std::vector<Eigen::Vector3d> positions;  // 2 frames x 3 joints
  for (int i = 0; i < 6; ++i) positions.emplace_back(i, 10 * i, 100 * i);
  write_positions_npy(path, 2, 3, positions, 0.5);
  const NpyArray a = read_npy(path);
  EXPECT_EQ(a.dtype, NpyDtype::kFloat32);
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3, 3}));
  const std::vector<float> v = a.to_float32();
  EXPECT_FLOAT_EQ(v[(1 * 3 + 2) * 3 + 1], 0.5f * 10 * 5);  // frame 1, joint 2, y
  EXPECT_FLOAT_EQ(v[(0 * 3 + 1) * 3 + 2], 0.5f * 100 * 1);
  EXPECT_THROW(write_positions_npy(path, 3, 3, positions), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::io
