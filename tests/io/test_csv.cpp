#include "io/csv.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;

using testing::make_temp_dir;

void expect_csv_error(const std::string& text, int line, const std::string& contains) {
  try {
    parse_control_csv(text, "c.csv");
    ADD_FAILURE() << "no error; expected " << contains;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), "c.csv");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(contains), std::string::npos) << e.what();
  }
}

TEST(Csv, PositionsHaveHeaderAndOneRowPerFrameAndJoint) {
  const std::vector<std::string> names = {"Hips", "Left,Hand \"L\""};
  const std::vector<Eigen::Vector3d> positions = {{0, 1, 2}, {0.5, -1.25, 3e-5}, {1, 2, 3}, {4, 5, 6}};
  const std::string text = format_positions_csv(names, 2, positions);
  EXPECT_EQ(text,
            "frame,joint,x,y,z\n"
            "0,Hips,0,1,2\n"
            "0,\"Left,Hand \"\"L\"\"\",0.5,-1.25,3e-05\n"
            "1,Hips,1,2,3\n"
            "1,\"Left,Hand \"\"L\"\"\",4,5,6\n");
  EXPECT_THROW(format_positions_csv(names, 3, positions), Error);
  const fs::path dir = make_temp_dir("csv_pos");
  const std::string path = (dir / "p.csv").string();
  write_positions_csv(path, names, 2, positions);
  EXPECT_EQ(read_file(path), text);
  fs::remove_all(dir);
}

TEST(Csv, ReadsControlsByColumnName) {
  const std::vector<Eigen::Vector3d> c = parse_control_csv("dx,dz,dtheta\n0,0,0\n0.01,0.02,-0.003\n", "c.csv");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[1], Eigen::Vector3d(0.01, 0.02, -0.003));
  // Other order, unit-suffixed names, extra columns, CRLF, spaces, blank lines, a quoted name.
  const std::vector<Eigen::Vector3d> d =
      parse_control_csv("\r\nframe, dtheta_rad ,\"dz_m\",dx_m\r\n0, 0.5, 2, 1\r\n\r\n1,+1e-3,4,3\r\n", "c.csv");
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0], Eigen::Vector3d(1, 2, 0.5));
  EXPECT_EQ(d[1], Eigen::Vector3d(3, 4, 0.001));
  EXPECT_TRUE(parse_control_csv("dx,dz,dtheta\n", "c.csv").empty());
}

// A t_s column gives the frame times (the file's own rate); they must increase.
TEST(Csv, ReadsControlFrameTimes) {
  std::vector<double> times;
  const auto c = parse_control_csv("t_s,dx,dz,dtheta\n0,0,0,0\n0.05,0.01,0.02,0\n0.1,0,0.02,0.1\n", "c.csv", &times);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(times, (std::vector<double>{0, 0.05, 0.1}));
  EXPECT_EQ(c[2], Eigen::Vector3d(0, 0.02, 0.1));
  parse_control_csv("dx,dz,dtheta,time_s\n0,0,0,1\n0,0,0,2\n", "c.csv", &times);
  EXPECT_EQ(times, (std::vector<double>{1, 2}));
  parse_control_csv("dx,dz,dtheta\n0,0,0\n", "c.csv", &times);
  EXPECT_TRUE(times.empty());
  expect_csv_error("t_s,dx,dz,dtheta\n0,0,0,0\n0.1,0,0,0\n0.1,0,0,0\n", 4, "increase");
  expect_csv_error("t_s,dx,dz,dtheta\n0.2,0,0,0\n\n0.1,0,0,0\n", 4, "increase");
}

TEST(Csv, ControlErrorsNameFileAndLine) {
  expect_csv_error("", 0, "empty");
  expect_csv_error("dx,dz\n1,2\n", 1, "'dtheta'");
  expect_csv_error("\n\ndx,dy,dtheta\n", 3, "'dz'");
  expect_csv_error("dx,dz,dtheta\n1,2,3\n1,2\n", 3, "row has 2 fields, the header has 3");
  expect_csv_error("dx,dz,dtheta\n1,2,3,4\n", 2, "row has 4 fields");
  expect_csv_error("dx,dz,dtheta\n1,abc,3\n", 2, "column 'dz': expected a finite number, found 'abc'");
  expect_csv_error("dx,dz,dtheta\n1,,3\n", 2, "column 'dz'");
  expect_csv_error("dx,dz,dtheta\n1,2,nan\n", 2, "column 'dtheta'");
  expect_csv_error("dx,dz,dtheta\n1,2,inf\n", 2, "finite");
  expect_csv_error("dx,dz,dtheta\n1,2 3,3\n", 2, "found '2 3'");
  expect_csv_error("dx,dx,dtheta\n", 1, "repeats");
  expect_csv_error("dx,,dtheta\n", 1, "no name");
  expect_csv_error("dx,\"dz,dtheta\n", 1, "unterminated");
}

TEST(Csv, NumericTableAndControlRoundTrip) {
  const fs::path dir = make_temp_dir("csv_table");
  CsvTable table;
  table.header = {"a", "b"};
  table.rows = {{1.0 / 3, -2}, {1e-20, 123456789}};
  const std::string path = (dir / "t.csv").string();
  write_numeric_csv(path, table);
  const CsvTable back = read_numeric_csv(path);
  EXPECT_EQ(back.header, table.header);
  ASSERT_EQ(back.rows.size(), 2u);
  EXPECT_NEAR(back.rows[0][0], 1.0 / 3, 1e-9);
  EXPECT_EQ(back.rows[1][1], 123456789);
  EXPECT_EQ(back.row_lines, (std::vector<int>{2, 3}));
  EXPECT_EQ(back.column("b"), 1);
  EXPECT_EQ(back.column("c"), -1);
  table.rows.push_back({1});
  EXPECT_THROW(format_numeric_csv(table), Error);

  const std::vector<Eigen::Vector3d> controls = {{0.1f, 0.2f, 0.3f}, {-1, 0, 1}};
  const std::string cpath = (dir / "c.csv").string();
  write_control_csv(cpath, controls);
  EXPECT_EQ(read_file(cpath).substr(0, 13), "dx,dz,dtheta\n");
  const std::vector<Eigen::Vector3d> again = read_control_csv(cpath);
  ASSERT_EQ(again.size(), 2u);
  for (size_t i = 0; i < 2; ++i) EXPECT_LT((again[i] - controls[i]).norm(), 1e-8);
  EXPECT_THROW(read_control_csv((dir / "missing.csv").string()), Error);
  // With a frame rate the file carries each frame's time.
  write_control_csv(cpath, controls, 20.0);
  EXPECT_EQ(read_file(cpath).substr(0, 17), "t_s,dx,dz,dtheta\n");
  std::vector<double> times;
  const std::vector<Eigen::Vector3d> timed = read_control_csv(cpath, &times);
  EXPECT_EQ(times, (std::vector<double>{0, 0.05}));
  for (size_t i = 0; i < 2; ++i) EXPECT_LT((timed[i] - controls[i]).norm(), 1e-8);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mosyn::io
