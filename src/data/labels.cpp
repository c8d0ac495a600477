#include "data/labels.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"

namespace mosyn::data {
namespace fs = std::filesystem;
namespace {

std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
    start = end + 1;
  }
  // A final newline does not start another line.
  while (!lines.empty() && trim(lines.back()).empty()) lines.pop_back();
  return lines;
}

// One label per line; line index = id. Blank lines inside the list would shift ids: rejected.
std::vector<std::string> read_label_file(const std::string& path) {
  if (!fs::is_regular_file(path)) throw Error(path + ": label file not found");
  std::string text = io::read_file(path);
  if (text.size() >= 3 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  const std::vector<std::string> lines = split_lines(text);
  if (lines.empty()) throw ParseError(path, 0, "no labels");
  std::vector<std::string> labels;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string name = strip_dataset_prefix(trim(lines[i]));
    if (name.empty()) throw ParseError(path, static_cast<int>(i + 1), "empty label (line index is the label id)");
    if (std::find(labels.begin(), labels.end(), name) != labels.end())
      throw ParseError(path, static_cast<int>(i + 1), "label '" + name + "' repeats");
    labels.push_back(name);
  }
  return labels;
}

// Splits one CSV record; fields may be double-quoted with "" for a quote.
std::vector<std::string> split_csv(const std::string& line, const std::string& file, int line_number) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.push_back(field);
      field.clear();
    } else {
      field += c;
    }
  }
  if (quoted) throw ParseError(file, line_number, "unterminated quoted field");
  fields.push_back(field);
  return fields;
}

void add_label(std::vector<std::string>* vocabulary, const std::string& name) {
  if (!name.empty() && std::find(vocabulary->begin(), vocabulary->end(), name) == vocabulary->end())
    vocabulary->push_back(name);
}

SourceListing list_bandai(const std::string& dir) {
  SourceListing out;
  out.dir = dir;
  out.layout = SourceLayout::kBandaiNamco;
  const std::string content_path = (fs::path(dir) / "cfg" / "content_label.txt").string();
  const std::string style_path = (fs::path(dir) / "cfg" / "style_label.txt").string();
  out.content_labels = read_label_file(content_path);
  out.style_labels = read_label_file(style_path);
  const fs::path data = fs::path(dir) / "data";
  if (!fs::is_directory(data)) throw Error(dir + ": Bandai-Namco layout without a data/ folder");
  for (const auto& entry : fs::directory_iterator(data)) {
    if (!entry.is_regular_file() || entry.path().extension() != ".bvh") continue;
    SourceFile f;
    f.path = entry.path().string();
    f.relative = "data/" + entry.path().filename().string();
    const fs::path json_path = fs::path(entry.path()).replace_extension(".json");
    if (!fs::is_regular_file(json_path)) throw Error(json_path.string() + ": label file missing for " + f.path);
    const nlohmann::json j = io::read_json(json_path.string());
    auto label = [&](const char* key, const std::vector<std::string>& vocabulary) -> std::string {
      if (!j.is_object() || !j.contains(key) || !j[key].is_number_integer())
        throw ParseError(json_path.string(), 0, std::string("expected an integer \"") + key + "\"");
      const long long id = j[key].get<long long>();
      if (id < 0 || id >= static_cast<long long>(vocabulary.size()))
        throw ParseError(json_path.string(), 0,
                         std::string(key) + " id " + std::to_string(id) + " is outside the " +
                             std::to_string(vocabulary.size()) + " labels of cfg/" + key + "_label.txt");
      return vocabulary[static_cast<size_t>(id)];
    };
    f.content = label("content", out.content_labels);
    f.style = label("style", out.style_labels);
    out.files.push_back(std::move(f));
  }
  return out;
}

SourceListing list_cmu(const std::string& dir) {
  SourceListing out;
  out.dir = dir;
  out.layout = SourceLayout::kCmu;
  const std::string index = (fs::path(dir) / "index.csv").string();
  std::string text = io::read_file(index);
  if (text.size() >= 3 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  const std::vector<std::string> lines = split_lines(text);
  if (lines.empty()) throw ParseError(index, 1, "empty index (expected a header with file and action columns)");
  const std::vector<std::string> header = split_csv(lines[0], index, 1);
  int file_col = -1, action_col = -1;
  for (size_t i = 0; i < header.size(); ++i) {
    if (trim(header[i]) == "file") file_col = static_cast<int>(i);
    if (trim(header[i]) == "action") action_col = static_cast<int>(i);
  }
  if (file_col < 0 || action_col < 0) throw ParseError(index, 1, "header must name the columns 'file' and 'action'");
  for (size_t i = 1; i < lines.size(); ++i) {
    const int line_number = static_cast<int>(i + 1);
    if (trim(lines[i]).empty()) continue;
    const std::vector<std::string> fields = split_csv(lines[i], index, line_number);
    if (fields.size() != header.size())
      throw ParseError(index, line_number,
                       "expected " + std::to_string(header.size()) + " fields, found " + std::to_string(fields.size()));
    SourceFile f;
    f.relative = trim(fields[file_col]);
    f.content = trim(fields[action_col]);
    if (f.relative.empty()) throw ParseError(index, line_number, "empty file name");
    if (f.content.empty()) throw ParseError(index, line_number, "empty action");
    f.path = (fs::path(dir) / f.relative).string();
    if (!fs::is_regular_file(f.path)) throw ParseError(index, line_number, "file not found: " + f.path);
    add_label(&out.content_labels, f.content);
    out.files.push_back(std::move(f));
  }
  return out;
}

SourceListing list_plain(const std::string& dir) {
  SourceListing out;
  out.dir = dir;
  out.layout = SourceLayout::kPlain;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".bvh") continue;
    SourceFile f;
    f.path = entry.path().string();
    f.relative = fs::relative(entry.path(), dir).generic_string();
    out.files.push_back(std::move(f));
  }
  return out;
}

}  // namespace

const char* to_string(SourceLayout layout) {
  switch (layout) {
    case SourceLayout::kBandaiNamco: return "bandai-namco";
    case SourceLayout::kCmu: return "cmu";
    case SourceLayout::kPlain: return "plain";
  }
  return "plain";
}

std::string strip_dataset_prefix(const std::string& label) {
  const std::string prefix = "dataset-";
  if (label.compare(0, prefix.size(), prefix) != 0) return label;
  size_t i = prefix.size();
  while (i < label.size() && std::isdigit(static_cast<unsigned char>(label[i]))) ++i;
  if (i == prefix.size() || i >= label.size() || label[i] != '_') return label;
  return label.substr(i + 1);
}

SourceListing list_source(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error(dir + ": not a directory");
  SourceListing out;
  if (fs::exists(fs::path(dir) / "cfg" / "content_label.txt") || fs::exists(fs::path(dir) / "cfg" / "style_label.txt"))
    out = list_bandai(dir);
  else if (fs::exists(fs::path(dir) / "index.csv"))
    out = list_cmu(dir);
  else
    out = list_plain(dir);
  if (out.files.empty()) throw Error(dir + ": no BVH files found");
  std::sort(out.files.begin(), out.files.end(),
            [](const SourceFile& a, const SourceFile& b) { return a.relative < b.relative; });
  return out;
}

void filter_source(SourceListing* listing, const std::vector<std::string>& contents,
                   const std::vector<std::string>& styles) {
  auto check = [&](const std::vector<std::string>& wanted, const std::vector<std::string>& vocabulary,
                   const char* what) {
    std::vector<std::string> names;
    for (const std::string& w : wanted) {
      const std::string name = strip_dataset_prefix(trim(w));
      if (vocabulary.empty())
        throw Error(listing->dir + ": cannot filter by " + what + ": the source has no " + what + " labels");
      if (std::find(vocabulary.begin(), vocabulary.end(), name) == vocabulary.end()) {
        std::string known;
        for (const std::string& v : vocabulary) known += (known.empty() ? "" : ", ") + v;
        throw Error(listing->dir + ": unknown " + what + " '" + name + "' (known: " + known + ")");
      }
      names.push_back(name);
    }
    return names;
  };
  const std::vector<std::string> c = check(contents, listing->content_labels, "content");
  const std::vector<std::string> s = check(styles, listing->style_labels, "style");
  std::vector<SourceFile> kept;
  for (SourceFile& f : listing->files) {
    if (!c.empty() && std::find(c.begin(), c.end(), f.content) == c.end()) continue;
    if (!s.empty() && std::find(s.begin(), s.end(), f.style) == s.end()) continue;
    kept.push_back(std::move(f));
  }
  listing->files = std::move(kept);
}

std::string mirrored_label(const std::string& label) {
  std::string out;
  size_t start = 0;
  while (start <= label.size()) {
    size_t end = label.find_first_of("-_", start);
    if (end == std::string::npos) end = label.size();
    const std::string word = label.substr(start, end - start);
    out += word == "left" ? "right" : word == "right" ? "left" : word;
    if (end < label.size()) out += label[end];
    start = end + 1;
  }
  return out;
}

}  // namespace mosyn::data
