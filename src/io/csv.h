// Comma-separated text files: world positions for inspection and plotting, numeric tables, and
// the per-frame control signal (dx, dz, dtheta) that drives synthesis.
//
// Written files use '\n' line ends, a header line, and numbers with 9 significant digits (enough
// for float32 exactly). Text fields containing a comma, quote or newline are quoted with
// doubled quotes (RFC 4180). Files are written atomically (io/atomic_file.h).
//
// Reading accepts LF or CRLF, spaces around fields, blank lines, and quoted header names; it
// throws mosyn::ParseError("file:line: message") naming the column on any problem.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace mosyn::io {

// World positions as CSV: header "frame,joint,x,y,z", then one row per frame and joint (frames
// outer, joints inner), joint given by name. positions is [T, J] row-major (index t * J + j), in
// whatever length unit the caller uses. Throws mosyn::Error when positions.size() != T * J.
std::string format_positions_csv(const std::vector<std::string>& joint_names, int num_frames,
                                 const std::vector<Eigen::Vector3d>& positions);
void write_positions_csv(const std::string& path, const std::vector<std::string>& joint_names, int num_frames,
                         const std::vector<Eigen::Vector3d>& positions);

// A table of numbers with named columns.
struct CsvTable {
  std::vector<std::string> header;        // [C] column names
  std::vector<std::vector<double>> rows;  // [N][C]
  std::vector<int> row_lines;             // [N] 1-based line of each row in the file (0 if made in memory)
  int header_line = 0;                    // 1-based line of the header in the file

  // Index of the column with this exact name, or -1.
  int column(const std::string& name) const;
};

// Parses a CSV whose first non-blank line is a header and whose other lines hold one finite
// number per column. Throws ParseError for a missing header, empty or repeated column names,
// rows with the wrong number of fields, and fields that are not finite numbers.
CsvTable parse_numeric_csv(const std::string& text, const std::string& file_name_for_errors);
CsvTable read_numeric_csv(const std::string& path);

// CSV text for a table (row_lines is ignored). Throws mosyn::Error when a row's length differs
// from the header's.
std::string format_numeric_csv(const CsvTable& table);
void write_numeric_csv(const std::string& path, const CsvTable& table);

// The per-frame control signal: one row per frame, (dx, dz, dtheta) = sideways and forward root
// displacement since the previous frame in the character's heading frame, and heading change in
// radians (see core/trajectory.h; the data layer uses metres). The columns are found by name:
// "dx" or "dx_m", "dz" or "dz_m", "dtheta" or "dtheta_rad", in any order; other columns are
// ignored. An optional "t_s" (or "time_s") column gives each frame's time in seconds, so the file
// says its own frame rate (a 30-fps take's control read by a 20-fps model walks at the take's speed,
// not two thirds of it); times_s, when given, receives it ([T], empty when the file has none).
// Throws ParseError when a column is missing (line 1 of the header), a value is bad, or the times
// do not increase (the line of the first that does not).
std::vector<Eigen::Vector3d> parse_control_csv(const std::string& text, const std::string& file_name_for_errors,
                                               std::vector<double>* times_s = nullptr);
std::vector<Eigen::Vector3d> read_control_csv(const std::string& path, std::vector<double>* times_s = nullptr);
// Writes controls with the header "dx,dz,dtheta", or "t_s,dx,dz,dtheta" (frame t at t / fps seconds)
// when fps > 0.
void write_control_csv(const std::string& path, const std::vector<Eigen::Vector3d>& controls, double fps = 0.0);

}  // namespace mosyn::io
