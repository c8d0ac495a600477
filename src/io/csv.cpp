#include "io/csv.h"

#include <charconv>
#include <cmath>
#include <set>
#include <string_view>
#include <utility>

#include "core/error.h"
#include "io/atomic_file.h"

namespace mosyn::io {
namespace {

void append_number(std::string* out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, 9);
  out->append(buffer, result.ptr);
}

void append_text_field(std::string* out, const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) {
    *out += text;
    return;
  }
  *out += '"';
  for (char c : text) {
    if (c == '"') *out += '"';
    *out += c;
  }
  *out += '"';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Splits one line at commas, honouring double-quoted fields ("a,b" and "" escapes).
std::vector<std::string> split_fields(std::string_view line, const std::string& file, int line_number) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  bool was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          quoted = false;
        }
      } else {
        field += c;
      }
    } else if (c == '"' && trim(field).empty()) {
      quoted = true;
      was_quoted = true;
      field.clear();
    } else if (c == ',') {
      fields.push_back(was_quoted ? field : std::string(trim(field)));
      field.clear();
      was_quoted = false;
    } else {
      field += c;
    }
  }
  if (quoted) throw ParseError(file, line_number, "unterminated quoted field");
  fields.push_back(was_quoted ? field : std::string(trim(field)));
  return fields;
}

std::string show(const std::string& s) { return "'" + (s.size() > 40 ? s.substr(0, 40) + "..." : s) + "'"; }

}  // namespace

std::string format_positions_csv(const std::vector<std::string>& joint_names, int num_frames,
                                 const std::vector<Eigen::Vector3d>& positions) {
  const size_t num_joints = joint_names.size();
  if (num_frames < 0 || positions.size() != static_cast<size_t>(num_frames) * num_joints)
    throw Error("positions CSV: " + std::to_string(positions.size()) + " positions for " + std::to_string(num_frames) +
                " frames x " + std::to_string(num_joints) + " joints");
  std::string out = "frame,joint,x,y,z\n";
  out.reserve(positions.size() * 48 + 32);
  for (int t = 0; t < num_frames; ++t) {
    for (size_t j = 0; j < num_joints; ++j) {
      const Eigen::Vector3d& p = positions[static_cast<size_t>(t) * num_joints + j];
      out += std::to_string(t);
      out += ',';
      append_text_field(&out, joint_names[j]);
      for (int i = 0; i < 3; ++i) {
        out += ',';
        append_number(&out, p[i]);
      }
      out += '\n';
    }
  }
  return out;
}

void write_positions_csv(const std::string& path, const std::vector<std::string>& joint_names, int num_frames,
                         const std::vector<Eigen::Vector3d>& positions) {
  write_file_atomically(path, format_positions_csv(joint_names, num_frames, positions));
}

int CsvTable::column(const std::string& name) const {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

CsvTable parse_numeric_csv(const std::string& text, const std::string& file) {
  CsvTable table;
  bool have_header = false;
  size_t pos = 0;
  int line_number = 0;
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) pos = 3;  // UTF-8 BOM
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string_view line = std::string_view(text).substr(pos, eol - pos);
    pos = eol + 1;
    ++line_number;
    if (trim(line).empty()) continue;
    std::vector<std::string> fields = split_fields(line, file, line_number);
    if (!have_header) {
      std::set<std::string> seen;
      for (size_t i = 0; i < fields.size(); ++i) {
        if (fields[i].empty()) throw ParseError(file, line_number, "header column " + std::to_string(i + 1) + " has no name");
        if (!seen.insert(fields[i]).second) throw ParseError(file, line_number, "header column " + show(fields[i]) + " repeats");
      }
      table.header = std::move(fields);
      table.header_line = line_number;
      have_header = true;
      continue;
    }
    if (fields.size() != table.header.size())
      throw ParseError(file, line_number, "row has " + std::to_string(fields.size()) + " fields, the header has " +
                                              std::to_string(table.header.size()));
    std::vector<double> row(fields.size());
    for (size_t i = 0; i < fields.size(); ++i) {
      const std::string& f = fields[i];
      const char* begin = f.data() + (!f.empty() && f[0] == '+' ? 1 : 0);
      const char* end = f.data() + f.size();
      const auto result = std::from_chars(begin, end, row[i]);
      if (f.empty() || result.ec != std::errc() || result.ptr != end || !std::isfinite(row[i]))
        throw ParseError(file, line_number, "column " + show(table.header[i]) + ": expected a finite number, found " + show(f));
    }
    table.rows.push_back(std::move(row));
    table.row_lines.push_back(line_number);
  }
  if (!have_header) throw ParseError(file, 0, "empty CSV file; expected a header line");
  return table;
}

CsvTable read_numeric_csv(const std::string& path) { return parse_numeric_csv(read_file(path), path); }

std::string format_numeric_csv(const CsvTable& table) {
  std::string out;
  for (size_t i = 0; i < table.header.size(); ++i) {
    if (i > 0) out += ',';
    append_text_field(&out, table.header[i]);
  }
  out += '\n';
  for (const std::vector<double>& row : table.rows) {
    if (row.size() != table.header.size())
      throw Error("CSV row has " + std::to_string(row.size()) + " values, the header " + std::to_string(table.header.size()));
    for (size_t i = 0; i < row.size(); ++i) {
      if (i > 0) out += ',';
      append_number(&out, row[i]);
    }
    out += '\n';
  }
  return out;
}

void write_numeric_csv(const std::string& path, const CsvTable& table) {
  write_file_atomically(path, format_numeric_csv(table));
}

std::vector<Eigen::Vector3d> parse_control_csv(const std::string& text, const std::string& file,
                                               std::vector<double>* times_s) {
  const CsvTable table = parse_numeric_csv(text, file);
  int columns[3];
  const char* names[3][2] = {{"dx", "dx_m"}, {"dz", "dz_m"}, {"dtheta", "dtheta_rad"}};
  for (int k = 0; k < 3; ++k) {
    columns[k] = table.column(names[k][0]);
    if (columns[k] < 0) columns[k] = table.column(names[k][1]);
    if (columns[k] < 0)
      throw ParseError(file, table.header_line,
                       std::string("control CSV has no '") + names[k][0] + "' (or '" + names[k][1] +
                           "') column; expected a header like dx,dz,dtheta");
  }
  int time_column = table.column("t_s");
  if (time_column < 0) time_column = table.column("time_s");
  std::vector<Eigen::Vector3d> controls;
  controls.reserve(table.rows.size());
  if (times_s) times_s->clear();
  for (size_t i = 0; i < table.rows.size(); ++i) {
    const std::vector<double>& row = table.rows[i];
    controls.emplace_back(row[static_cast<size_t>(columns[0])], row[static_cast<size_t>(columns[1])],
                          row[static_cast<size_t>(columns[2])]);
    if (time_column < 0) continue;
    const double t = row[static_cast<size_t>(time_column)];
    if (i > 0 && !(t > table.rows[i - 1][static_cast<size_t>(time_column)]))
      throw ParseError(file, table.row_lines[i], "the times (t_s) must increase from row to row");
    if (times_s) times_s->push_back(t);
  }
  return controls;
}

std::vector<Eigen::Vector3d> read_control_csv(const std::string& path, std::vector<double>* times_s) {
  return parse_control_csv(read_file(path), path, times_s);
}

void write_control_csv(const std::string& path, const std::vector<Eigen::Vector3d>& controls, double fps) {
  CsvTable table;
  table.header = {"dx", "dz", "dtheta"};
  if (fps > 0) table.header.insert(table.header.begin(), "t_s");
  for (size_t t = 0; t < controls.size(); ++t) {
    std::vector<double> row = {controls[t][0], controls[t][1], controls[t][2]};
    if (fps > 0) row.insert(row.begin(), static_cast<double>(t) / fps);
    table.rows.push_back(std::move(row));
  }
  write_numeric_csv(path, table);
}

}  // namespace mosyn::io
