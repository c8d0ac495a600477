#include "io/bvh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <unordered_set>

#include "core/error.h"
#include "core/rotation.h"
#include "io/atomic_file.h"

namespace mosyn::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;
constexpr double kRadPerDeg = kPi / 180.0;

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

char lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (lower(a[i]) != lower(b[i])) return false;
  return true;
}

// A token for an error message: quoted, at most 40 characters, non-printable bytes escaped.
std::string quote(std::string_view token) {
  std::string out = "'";
  const size_t n = std::min<size_t>(token.size(), 40);
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (c >= 32 && c < 127) {
      out += static_cast<char>(c);
    } else {
      static const char* kHex = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  if (token.size() > n) out += "...";
  return out + "'";
}

bool parse_channel_name(std::string_view name, BvhChannel* channel) {
  static const std::pair<const char*, BvhChannel> kNames[] = {
      {"Xposition", BvhChannel::kXposition}, {"Yposition", BvhChannel::kYposition},
      {"Zposition", BvhChannel::kZposition}, {"Xrotation", BvhChannel::kXrotation},
      {"Yrotation", BvhChannel::kYrotation}, {"Zrotation", BvhChannel::kZrotation}};
  for (const auto& [text, value] : kNames)
    if (iequals(name, text)) {
      *channel = value;
      return true;
    }
  return false;
}

// Parses a whole token as a finite double; accepts a leading '+', which from_chars does not.
enum class NumberStatus { kOk, kNotANumber, kOutOfRange, kNotFinite };

// Clinger's fast path for plain decimals such as "-6.77137" or "5.1072e-06": when the digits form
// an integer below 2^53 and the power of ten is at most 22, mantissa * 10^e (or / 10^-e) is a
// single correctly rounded operation on exact doubles, i.e. the same result as from_chars.
// Returns false (caller falls back to from_chars) for anything else.
bool parse_double_fast(const char* p, const char* end, double* value) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                      1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  bool negative = false;
  if (p != end && (*p == '-' || *p == '+')) {
    negative = *p == '-';
    ++p;
  }
  uint64_t mantissa = 0;
  int digits = 0;
  int exponent = 0;
  bool any_digit = false;
  while (p != end && static_cast<unsigned>(*p - '0') < 10) {
    mantissa = mantissa * 10 + static_cast<unsigned>(*p - '0');
    digits += mantissa != 0;
    any_digit = true;
    ++p;
  }
  if (p != end && *p == '.') {
    ++p;
    while (p != end && static_cast<unsigned>(*p - '0') < 10) {
      mantissa = mantissa * 10 + static_cast<unsigned>(*p - '0');
      digits += mantissa != 0;
      --exponent;
      any_digit = true;
      ++p;
    }
  }
  if (!any_digit || digits > 15) return false;  // 15 digits < 2^53: exact
  if (p != end && (*p == 'e' || *p == 'E')) {
    ++p;
    bool exp_negative = false;
    if (p != end && (*p == '-' || *p == '+')) {
      exp_negative = *p == '-';
      ++p;
    }
    if (p == end || static_cast<unsigned>(*p - '0') >= 10) return false;
    int e = 0;
    while (p != end && static_cast<unsigned>(*p - '0') < 10 && e < 1000) {
      e = e * 10 + (*p - '0');
      ++p;
    }
    exponent += exp_negative ? -e : e;
  }
  if (p != end || exponent < -22 || exponent > 22) return false;
  double v = static_cast<double>(mantissa);
  v = exponent < 0 ? v / kPow10[-exponent] : v * kPow10[exponent];
  *value = negative ? -v : v;
  return true;
}

NumberStatus parse_double(const char* begin, const char* end, double* value) {
  if (parse_double_fast(begin, end, value)) return NumberStatus::kOk;
  const char* p = begin;
  if (p != end && *p == '+') ++p;
  if (p == end || *p == '+' || (*p == '-' && p != begin)) return NumberStatus::kNotANumber;
  const auto result = std::from_chars(p, end, *value);
  if (result.ec == std::errc::result_out_of_range) return NumberStatus::kOutOfRange;
  if (result.ec != std::errc() || result.ptr != end) return NumberStatus::kNotANumber;
  if (!std::isfinite(*value)) return NumberStatus::kNotFinite;
  return NumberStatus::kOk;
}

// Splits text into tokens: '{' and '}' are tokens of their own, anything else is a run of
// characters that are neither whitespace nor braces. Tracks 1-based line numbers.
class Tokenizer {
 public:
  Tokenizer(const std::string& text, const std::string& file) : p_(text.data()), end_(text.data() + text.size()), file_(file) {
    if (end_ - p_ >= 3 && static_cast<unsigned char>(p_[0]) == 0xEF && static_cast<unsigned char>(p_[1]) == 0xBB &&
        static_cast<unsigned char>(p_[2]) == 0xBF)
      p_ += 3;
  }

  // The next token (empty at the end of the text); *line receives its line number.
  std::string_view next(int* line = nullptr) {
    skip_space();
    if (line) *line = line_;
    if (p_ == end_) return {};
    const char* start = p_;
    if (*p_ == '{' || *p_ == '}') {
      ++p_;
    } else {
      while (p_ != end_ && !is_space(*p_) && *p_ != '{' && *p_ != '}') ++p_;
    }
    return std::string_view(start, static_cast<size_t>(p_ - start));
  }

  std::string_view peek(int* line = nullptr) {
    const char* saved_p = p_;
    const int saved_line = line_;
    const std::string_view token = next(line);
    p_ = saved_p;
    line_ = saved_line;
    return token;
  }

  void skip_space() {
    while (p_ != end_ && is_space(*p_)) {
      if (*p_ == '\n') ++line_;
      ++p_;
    }
  }

  [[noreturn]] void fail(int line, const std::string& message) const { throw ParseError(file_, line, message); }

  double number(const char* what) {
    int line = 0;
    const std::string_view token = next(&line);
    if (token.empty()) fail(line, std::string("unexpected end of file; expected ") + what);
    double value = 0;
    switch (parse_double(token.data(), token.data() + token.size(), &value)) {
      case NumberStatus::kOk: return value;
      case NumberStatus::kOutOfRange: fail(line, std::string("number out of range ") + quote(token) + " for " + what);
      case NumberStatus::kNotFinite: fail(line, std::string("non-finite number ") + quote(token) + " for " + what);
      case NumberStatus::kNotANumber: break;
    }
    fail(line, std::string("expected ") + what + ", found " + quote(token));
  }

  const char* position() const { return p_; }
  const char* end() const { return end_; }
  int line() const { return line_; }
  const std::string& file() const { return file_; }

 private:
  const char* p_;
  const char* end_;
  int line_ = 1;
  const std::string& file_;
};

struct OpenBlock {
  int joint = -1;            // the joint, or the End Site's parent joint
  bool end_site = false;
  bool has_offset = false;
  bool has_channels = false;
  int line = 0;              // where the block was opened
};

class BvhParser {
 public:
  BvhParser(const std::string& text, const std::string& file) : tok_(text, file) {}

  BvhFile parse() {
    int line = 0;
    std::string_view token = tok_.next(&line);
    if (token.empty()) tok_.fail(line, "file is empty; expected HIERARCHY");
    if (!iequals(token, "HIERARCHY")) tok_.fail(line, "expected HIERARCHY, found " + quote(token));
    token = tok_.next(&line);
    if (!iequals(token, "ROOT"))
      tok_.fail(line, "expected ROOT, found " + (token.empty() ? std::string("end of file") : quote(token)));
    open_joint(line, -1);
    parse_hierarchy();
    parse_motion_header();
    parse_values();
    bvh_.skeleton.meters_per_unit = 1.0;
    bvh_.skeleton.up_axis = 1;
    return std::move(bvh_);
  }

 private:
  // Reads a joint name (the rest of the line up to '{', words joined by one space) and '{'.
  void open_joint(int keyword_line, int parent) {
    int line = 0;
    std::string_view token = tok_.next(&line);
    if (token.empty() || token == "{" || token == "}" || line != keyword_line)
      tok_.fail(keyword_line, "expected a joint name after " + std::string(parent < 0 ? "ROOT" : "JOINT"));
    std::string name(token);
    for (;;) {
      int next_line = 0;
      const std::string_view more = tok_.peek(&next_line);
      if (more.empty() || more == "{" || more == "}" || next_line != keyword_line) break;
      tok_.next();
      name += ' ';
      name += more;
    }
    Skeleton& sk = bvh_.skeleton;
    if (sk.num_joints() >= kBvhMaxJoints)
      tok_.fail(line, "more than " + std::to_string(kBvhMaxJoints) + " joints");
    if (static_cast<int>(stack_.size()) >= kBvhMaxDepth)
      tok_.fail(line, "joints nested deeper than " + std::to_string(kBvhMaxDepth) + " levels");
    if (!names_.insert(name).second) tok_.fail(line, "duplicate joint name " + quote(name));
    token = tok_.next(&line);
    if (token != "{")
      tok_.fail(line, "expected '{' after joint " + quote(name) + ", found " +
                          (token.empty() ? std::string("end of file") : quote(token)));
    sk.joint_names.push_back(std::move(name));
    sk.parents.push_back(parent);
    sk.offsets.emplace_back(0, 0, 0);
    bvh_.channels.emplace_back();
    OpenBlock block;
    block.joint = sk.num_joints() - 1;
    block.line = keyword_line;
    stack_.push_back(block);
  }

  std::string block_name(const OpenBlock& b) const {
    const std::string& joint = bvh_.skeleton.joint_names[static_cast<size_t>(b.joint)];
    return b.end_site ? "End Site of joint " + quote(joint) : "joint " + quote(joint);
  }

  void parse_offset(OpenBlock& block, int line) {
    if (block.has_offset) tok_.fail(line, "second OFFSET in " + block_name(block));
    block.has_offset = true;
    Eigen::Vector3d offset;
    for (int i = 0; i < 3; ++i) offset[i] = tok_.number("an OFFSET coordinate (3 numbers)");
    if (block.end_site) {
      bvh_.skeleton.end_sites.back().offset = offset;
    } else {
      bvh_.skeleton.offsets[static_cast<size_t>(block.joint)] = offset;
    }
  }

  void parse_channels(OpenBlock& block, int line) {
    if (block.has_channels) tok_.fail(line, "second CHANNELS in " + block_name(block));
    block.has_channels = true;
    int count_line = 0;
    const std::string_view count_text = tok_.next(&count_line);
    int count = -1;
    const auto result = std::from_chars(count_text.data(), count_text.data() + count_text.size(), count);
    if (count_text.empty() || result.ec != std::errc() || result.ptr != count_text.data() + count_text.size())
      tok_.fail(count_line, "expected the number of channels after CHANNELS, found " +
                                (count_text.empty() ? std::string("end of file") : quote(count_text)));
    if (count < 0 || count > 6)
      tok_.fail(count_line, "CHANNELS count must be 0 to 6, found " + std::string(count_text));
    BvhChannelLayout& layout = bvh_.channels[static_cast<size_t>(block.joint)];
    for (int i = 0; i < count; ++i) {
      int name_line = 0;
      const std::string_view name = tok_.next(&name_line);
      BvhChannel channel;
      if (!parse_channel_name(name, &channel)) {
        const bool keyword = name.empty() || name == "{" || name == "}" || iequals(name, "JOINT") ||
                             iequals(name, "End") || iequals(name, "OFFSET") || iequals(name, "CHANNELS") ||
                             iequals(name, "MOTION");
        if (keyword)
          tok_.fail(name_line, "CHANNELS " + std::to_string(count) + " lists only " + std::to_string(i) +
                                   " channel names in " + block_name(block));
        tok_.fail(name_line, "unknown channel " + quote(name) + " (expected Xposition, Yposition, Zposition, "
                             "Xrotation, Yrotation or Zrotation)");
      }
      if (std::find(layout.begin(), layout.end(), channel) != layout.end())
        tok_.fail(name_line, "channel " + quote(name) + " repeats in " + block_name(block));
      layout.push_back(channel);
    }
    int extra_line = 0;
    const std::string_view extra = tok_.peek(&extra_line);
    BvhChannel ignored;
    if (parse_channel_name(extra, &ignored))
      tok_.fail(extra_line, "CHANNELS " + std::to_string(count) + " is followed by more than " +
                                std::to_string(count) + " channel names in " + block_name(block));
  }

  // Everything after "ROOT name {" up to the matching '}'. An explicit stack, no recursion.
  void parse_hierarchy() {
    while (!stack_.empty()) {
      int line = 0;
      const std::string_view token = tok_.next(&line);
      OpenBlock& block = stack_.back();
      if (token.empty()) {
        tok_.fail(line, "unexpected end of file inside " + block_name(block) + " opened at line " +
                            std::to_string(block.line) + "; expected '}'");
      } else if (token == "}") {
        if (!block.has_offset) tok_.fail(line, block_name(block) + " has no OFFSET");
        stack_.pop_back();
      } else if (iequals(token, "OFFSET")) {
        parse_offset(block, line);
      } else if (block.end_site) {
        tok_.fail(line, "expected OFFSET or '}' in " + block_name(block) + ", found " + quote(token));
      } else if (iequals(token, "CHANNELS")) {
        parse_channels(block, line);
      } else if (iequals(token, "JOINT")) {
        open_joint(line, block.joint);
      } else if (iequals(token, "End")) {
        int site_line = 0;
        const std::string_view site = tok_.next(&site_line);
        if (!iequals(site, "Site")) tok_.fail(site_line, "expected 'Site' after 'End'");
        const std::string_view brace = tok_.next(&site_line);
        if (brace != "{") tok_.fail(site_line, "expected '{' after End Site");
        EndSite end_site;
        end_site.parent = block.joint;
        bvh_.skeleton.end_sites.push_back(end_site);
        OpenBlock site_block;
        site_block.joint = block.joint;
        site_block.end_site = true;
        site_block.line = line;
        stack_.push_back(site_block);  // invalidates `block`
      } else if (iequals(token, "ROOT")) {
        tok_.fail(line, "ROOT inside " + block_name(block) + " (opened at line " + std::to_string(block.line) +
                            "); a file with several roots is not supported");
      } else if (iequals(token, "MOTION")) {
        tok_.fail(line, "MOTION before the hierarchy is complete: " + block_name(block) + " opened at line " +
                            std::to_string(block.line) + " has no closing '}'");
      } else {
        tok_.fail(line, "unexpected " + quote(token) + " in " + block_name(block) +
                            "; expected OFFSET, CHANNELS, JOINT, End Site or '}'");
      }
    }
  }

  // Reads "<label>:" (label letters in any case; any split into tokens, e.g. "Frame" "Time:" or
  // "Frames:12") and returns the value text that follows it.
  std::string labelled_value(std::string_view label, const char* display, int* value_line) {
    std::string want(label);
    want += ':';
    std::string seen;
    int line = 0;
    while (seen.size() < want.size()) {
      int token_line = 0;
      const std::string_view token = tok_.next(&token_line);
      if (line == 0) line = token_line;
      if (token.empty()) tok_.fail(token_line, std::string("unexpected end of file; expected '") + display + "'");
      // Bounded: a huge garbage token must not be copied whole.
      for (size_t i = 0; i < token.size() && seen.size() < want.size() + 400; ++i) seen += lower(token[i]);
      const size_t n = std::min(seen.size(), want.size());
      if (seen.compare(0, n, want, 0, n) != 0)
        tok_.fail(token_line, std::string("expected '") + display + "', found " + quote(token));
    }
    *value_line = line;
    if (seen.size() > want.size()) return seen.substr(want.size());
    const std::string_view value = tok_.next(value_line);
    if (value.empty()) tok_.fail(*value_line, std::string("unexpected end of file; expected a value after '") + display + "'");
    return std::string(value);
  }

  void parse_motion_header() {
    int line = 0;
    std::string_view token = tok_.next(&line);
    if (token.empty()) tok_.fail(line, "unexpected end of file; expected MOTION");
    if (iequals(token, "ROOT")) tok_.fail(line, "a second ROOT is not supported");
    if (token == "}") tok_.fail(line, "unbalanced '}': the ROOT joint is already closed");
    if (!iequals(token, "MOTION")) tok_.fail(line, "expected MOTION after the hierarchy, found " + quote(token));

    const std::string frames_text = labelled_value("frames", "Frames:", &frames_line_);
    int64_t frames = -1;
    const auto result = std::from_chars(frames_text.data(), frames_text.data() + frames_text.size(), frames);
    if (result.ec == std::errc::result_out_of_range || (result.ec == std::errc() && frames > std::numeric_limits<int>::max()))
      tok_.fail(frames_line_, "Frames: " + frames_text.substr(0, 40) + " is too large");
    if (result.ec != std::errc() || result.ptr != frames_text.data() + frames_text.size())
      tok_.fail(frames_line_, "expected a whole number of frames after 'Frames:', found " + quote(frames_text));
    if (frames < 0) tok_.fail(frames_line_, "Frames: must not be negative, found " + frames_text);
    bvh_.num_frames = static_cast<int>(frames);

    int time_line = 0;
    const std::string time_text = labelled_value("frametime", "Frame Time:", &time_line);
    double frame_time = 0;
    const NumberStatus status = parse_double(time_text.data(), time_text.data() + time_text.size(), &frame_time);
    if (status != NumberStatus::kOk || !(frame_time > 0))
      tok_.fail(time_line, "Frame Time: must be a positive number of seconds, found " + quote(time_text));
    bvh_.frame_time_s = frame_time;
  }

  // The motion table: a hand-written scanner (this is where large files spend their time).
  void parse_values() {
    const uint64_t channels = static_cast<uint64_t>(bvh_.num_channels());
    const uint64_t frames = static_cast<uint64_t>(bvh_.num_frames);
    const uint64_t expected = frames * channels;
    if (channels == 0 && frames > 0)
      tok_.fail(frames_line_, "Frames: " + std::to_string(frames) + " but no joint has CHANNELS");
    const char* p = tok_.position();
    const char* const end = tok_.end();
    // Each value needs at least one character and a separator: never reserve more than that.
    const uint64_t room = static_cast<uint64_t>(end - p) / 2 + 1;
    std::vector<double>& values = bvh_.values;
    values.reserve(static_cast<size_t>(std::min(expected, room)));

    int line = tok_.line();
    uint64_t count = 0;
    uint64_t on_line = 0;
    int first_bad_line = 0;
    uint64_t first_bad_count = 0;
    int excess_line = 0;
    int last_data_line = line;
    auto end_line = [&]() {
      if (on_line > 0 && on_line != channels && first_bad_line == 0) {
        first_bad_line = line;
        first_bad_count = on_line;
      }
      on_line = 0;
    };
    while (p != end) {
      const char c = *p;
      if (c == '\n') {
        end_line();
        ++line;
        ++p;
        continue;
      }
      if (is_space(c)) {
        ++p;
        continue;
      }
      const char* start = p;
      while (p != end && !is_space(*p)) ++p;
      double value = 0;
      const NumberStatus status = parse_double(start, p, &value);
      if (status != NumberStatus::kOk) {
        const std::string_view token(start, static_cast<size_t>(p - start));
        if (status == NumberStatus::kNotFinite) tok_.fail(line, "non-finite value " + quote(token) + " in the motion data");
        if (status == NumberStatus::kOutOfRange) tok_.fail(line, "value out of range " + quote(token) + " in the motion data");
        tok_.fail(line, "expected a number in the motion data, found " + quote(token));
      }
      if (count < expected) {
        values.push_back(value);
      } else if (excess_line == 0) {
        excess_line = line;
      }
      ++count;
      ++on_line;
      last_data_line = line;
    }
    end_line();
    if (count == expected) return;  // frames may wrap over lines; only the total matters
    const std::string summary = "Frames: " + std::to_string(frames) + " x " + std::to_string(channels) +
                                " channels needs " + std::to_string(expected) + " values, found " + std::to_string(count);
    if (first_bad_line != 0)
      tok_.fail(first_bad_line, "motion data line has " + std::to_string(first_bad_count) + " values, expected " +
                                    std::to_string(channels) + " (" + summary + ")");
    if (count < expected)
      tok_.fail(last_data_line, "only " + std::to_string(count / std::max<uint64_t>(channels, 1)) +
                                    " frames of motion data (" + summary + "; truncated file?)");
    tok_.fail(excess_line, "more motion data than Frames: declares (" + summary + ")");
  }

  Tokenizer tok_;
  BvhFile bvh_;
  std::vector<OpenBlock> stack_;
  std::unordered_set<std::string> names_;
  int frames_line_ = 0;
};

void check_layout(const BvhChannelLayout& layout, const std::string& joint) {
  if (layout.size() > 6) throw Error("BVH joint '" + joint + "' has more than 6 channels");
  for (size_t i = 0; i < layout.size(); ++i)
    for (size_t k = 0; k < i; ++k)
      if (layout[i] == layout[k]) throw Error("BVH joint '" + joint + "' repeats channel " + to_string(layout[i]));
}

// Checks that a BvhFile's arrays agree with each other.
void check_consistent(const BvhFile& bvh) {
  bvh.skeleton.validate();
  const size_t num_joints = static_cast<size_t>(bvh.skeleton.num_joints());
  if (bvh.channels.size() != num_joints)
    throw Error("BVH has " + std::to_string(bvh.channels.size()) + " channel layouts for " +
                std::to_string(num_joints) + " joints");
  for (size_t j = 0; j < num_joints; ++j) check_layout(bvh.channels[j], bvh.skeleton.joint_names[j]);
  if (bvh.num_frames < 0) throw Error("BVH has a negative number of frames");
  if (!(bvh.frame_time_s > 0) || !std::isfinite(bvh.frame_time_s)) throw Error("BVH frame time must be positive");
  const size_t expected = static_cast<size_t>(bvh.num_frames) * static_cast<size_t>(bvh.num_channels());
  if (bvh.values.size() != expected)
    throw Error("BVH has " + std::to_string(bvh.values.size()) + " values; " + std::to_string(bvh.num_frames) +
                " frames x " + std::to_string(bvh.num_channels()) + " channels needs " + std::to_string(expected));
}

// A name parse_bvh would read back unchanged: not empty, no braces, no whitespace but single
// interior spaces.
bool is_writable_name(const std::string& name) {
  if (name.empty() || name.front() == ' ' || name.back() == ' ') return false;
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '{' || c == '}' || (is_space(c) && c != ' ') || (c == ' ' && name[i - 1] == ' ')) return false;
  }
  return true;
}

void append_number(std::string* out, double value, int significant_digits) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, significant_digits);
  out->append(buffer, result.ptr);
}

void append_indent(std::string* out, int depth) { out->append(static_cast<size_t>(depth), '\t'); }

// 2 pi multiple that brings angle closest to reference.
double unwrap_near(double angle, double reference) {
  return angle + 2 * kPi * std::round((reference - angle) / (2 * kPi));
}

// How one joint's rotation is written: the Euler order used for decomposition and, for each
// rotation channel in file order, which of the three angles it takes.
struct RotationPlan {
  int num_rotation_channels = 0;
  EulerOrder order = EulerOrder::kZYX;
};

RotationPlan plan_rotation(const BvhChannelLayout& layout) {
  RotationPlan plan;
  std::string axes;
  for (BvhChannel c : layout)
    if (is_rotation(c)) axes += static_cast<char>('X' + channel_axis(c));
  plan.num_rotation_channels = static_cast<int>(axes.size());
  // Fewer than three axes: complete the order with the missing ones (their angles are dropped).
  for (char a : std::string("XYZ"))
    if (axes.find(a) == std::string::npos) axes += a;
  plan.order = *parse_euler_order(axes);
  return plan;
}

}  // namespace

const char* to_string(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition: return "Xposition";
    case BvhChannel::kYposition: return "Yposition";
    case BvhChannel::kZposition: return "Zposition";
    case BvhChannel::kXrotation: return "Xrotation";
    case BvhChannel::kYrotation: return "Yrotation";
    case BvhChannel::kZrotation: return "Zrotation";
  }
  return "?";
}

int channel_axis(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition:
    case BvhChannel::kXrotation: return 0;
    case BvhChannel::kYposition:
    case BvhChannel::kYrotation: return 1;
    case BvhChannel::kZposition:
    case BvhChannel::kZrotation: return 2;
  }
  return 0;
}

bool is_rotation(BvhChannel channel) {
  return channel == BvhChannel::kXrotation || channel == BvhChannel::kYrotation || channel == BvhChannel::kZrotation;
}

int BvhFile::num_channels() const {
  size_t n = 0;
  for (const BvhChannelLayout& c : channels) n += c.size();
  return static_cast<int>(n);
}

int BvhFile::first_channel(int j) const {
  size_t n = 0;
  for (int k = 0; k < j; ++k) n += channels[static_cast<size_t>(k)].size();
  return static_cast<int>(n);
}

BvhFile parse_bvh(const std::string& text, const std::string& file_name_for_errors) {
  return BvhParser(text, file_name_for_errors).parse();
}

BvhFile read_bvh(const std::string& path) { return parse_bvh(read_file(path), path); }

std::string format_bvh(const BvhFile& bvh, int significant_digits) {
  check_consistent(bvh);
  if (significant_digits < 1 || significant_digits > 17) throw Error("format_bvh: significant_digits must be 1 to 17");
  const Skeleton& sk = bvh.skeleton;
  const int num_joints = sk.num_joints();
  for (double v : bvh.values)
    if (!std::isfinite(v)) throw Error("format_bvh: a motion value is not finite");

  std::vector<std::vector<int>> end_sites_of(static_cast<size_t>(num_joints));
  for (size_t e = 0; e < sk.end_sites.size(); ++e) end_sites_of[static_cast<size_t>(sk.end_sites[e].parent)].push_back(static_cast<int>(e));

  std::string out;
  out.reserve(bvh.values.size() * 10 + static_cast<size_t>(num_joints) * 200 + 256);
  out += "HIERARCHY\n";
  auto append_offset = [&](const Eigen::Vector3d& o, int depth) {
    if (!o.allFinite()) throw Error("format_bvh: an OFFSET is not finite");
    append_indent(&out, depth);
    out += "OFFSET";
    for (int i = 0; i < 3; ++i) {
      out += ' ';
      append_number(&out, o[i], significant_digits);
    }
    out += '\n';
  };
  std::vector<int> open;  // the path of joints whose blocks are open
  auto close_top = [&]() {
    append_indent(&out, static_cast<int>(open.size()) - 1);
    out += "}\n";
    open.pop_back();
  };
  for (int j = 0; j < num_joints; ++j) {
    const int parent = sk.parents[static_cast<size_t>(j)];
    while (!open.empty() && open.back() != parent) close_top();
    if (parent >= 0 && open.empty())
      throw Error("format_bvh: joints are not in depth-first pre-order (joint '" + sk.joint_names[static_cast<size_t>(j)] +
                  "' does not follow its parent's subtree)");
    if (!is_writable_name(sk.joint_names[static_cast<size_t>(j)]))
      throw Error("format_bvh: joint name '" + sk.joint_names[static_cast<size_t>(j)] +
                  "' cannot be written to BVH (empty, braces, or whitespace other than single spaces)");
    const int depth = static_cast<int>(open.size());
    append_indent(&out, depth);
    out += parent < 0 ? "ROOT " : "JOINT ";
    out += sk.joint_names[static_cast<size_t>(j)];
    out += '\n';
    append_indent(&out, depth);
    out += "{\n";
    append_offset(sk.offsets[static_cast<size_t>(j)], depth + 1);
    const BvhChannelLayout& layout = bvh.channels[static_cast<size_t>(j)];
    append_indent(&out, depth + 1);
    out += "CHANNELS " + std::to_string(layout.size());
    for (BvhChannel c : layout) {
      out += ' ';
      out += to_string(c);
    }
    out += '\n';
    for (int e : end_sites_of[static_cast<size_t>(j)]) {
      append_indent(&out, depth + 1);
      out += "End Site\n";
      append_indent(&out, depth + 1);
      out += "{\n";
      append_offset(sk.end_sites[static_cast<size_t>(e)].offset, depth + 2);
      append_indent(&out, depth + 1);
      out += "}\n";
    }
    open.push_back(j);
  }
  while (!open.empty()) close_top();

  out += "MOTION\nFrames: " + std::to_string(bvh.num_frames) + "\nFrame Time: ";
  append_number(&out, bvh.frame_time_s, 17);
  out += '\n';
  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  for (size_t t = 0; t < static_cast<size_t>(bvh.num_frames); ++t) {
    const double* row = bvh.values.data() + t * num_channels;
    for (size_t c = 0; c < num_channels; ++c) {
      if (c > 0) out += ' ';
      append_number(&out, row[c], significant_digits);
    }
    out += '\n';
  }
  return out;
}

void write_bvh(const std::string& path, const BvhFile& bvh, int significant_digits) {
  write_file_atomically(path, format_bvh(bvh, significant_digits));
}

Clip to_clip(const BvhFile& bvh) {
  check_consistent(bvh);
  Clip clip;
  clip.skeleton = bvh.skeleton;
  Motion& m = clip.motion;
  const int num_joints = bvh.skeleton.num_joints();
  m.fps = 1.0 / bvh.frame_time_s;
  m.num_frames = bvh.num_frames;
  m.num_joints = num_joints;
  const size_t n = static_cast<size_t>(m.num_frames) * static_cast<size_t>(num_joints);
  m.rotations.assign(n, Eigen::Quaterniond::Identity());
  m.translations.resize(n);
  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  for (int t = 0; t < m.num_frames; ++t) {
    const double* row = bvh.values.data() + static_cast<size_t>(t) * num_channels;
    size_t column = 0;
    for (int j = 0; j < num_joints; ++j) {
      Eigen::Vector3d translation = bvh.skeleton.offsets[static_cast<size_t>(j)];
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      for (BvhChannel c : bvh.channels[static_cast<size_t>(j)]) {
        const double v = row[column++];
        if (is_rotation(c)) {
          q = q * quat_about_axis(channel_axis(c), v * kRadPerDeg);
        } else {
          translation[channel_axis(c)] = v;
        }
      }
      q.normalize();
      if (t > 0 && q.dot(m.rotation(t - 1, j)) < 0) q.coeffs() = -q.coeffs();
      m.rotation(t, j) = q;
      m.translation(t, j) = translation;
    }
  }
  return clip;
}

BvhFile from_clip(const Clip& clip, const BvhFile* layout_template) {
  const Skeleton& sk = clip.skeleton;
  const Motion& m = clip.motion;
  sk.validate();
  const int num_joints = sk.num_joints();
  if (m.num_joints != num_joints)
    throw Error("from_clip: motion has " + std::to_string(m.num_joints) + " joints, skeleton " + std::to_string(num_joints));
  m.validate();

  BvhFile bvh;
  bvh.skeleton = sk;
  bvh.frame_time_s = 1.0 / m.fps;
  bvh.num_frames = m.num_frames;
  if (layout_template != nullptr) {
    const Skeleton& tk = layout_template->skeleton;
    if (tk.joint_names != sk.joint_names)
      throw Error("from_clip: the layout template's joints (" + std::to_string(tk.num_joints()) +
                  ") differ from the clip's (" + std::to_string(num_joints) + ") in number, names or order");
    if (layout_template->channels.size() != static_cast<size_t>(num_joints))
      throw Error("from_clip: the layout template has " + std::to_string(layout_template->channels.size()) +
                  " channel layouts for " + std::to_string(num_joints) + " joints");
    bvh.channels = layout_template->channels;
    for (int j = 0; j < num_joints; ++j) check_layout(bvh.channels[static_cast<size_t>(j)], sk.joint_names[static_cast<size_t>(j)]);
  } else {
    const BvhChannelLayout kPosition = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
    const BvhChannelLayout kRotation = {BvhChannel::kZrotation, BvhChannel::kYrotation, BvhChannel::kXrotation};
    bvh.channels.resize(static_cast<size_t>(num_joints));
    for (int j = 0; j < num_joints; ++j) {
      bool animated = j == 0;
      const Eigen::Vector3d& offset = sk.offsets[static_cast<size_t>(j)];
      for (int t = 0; t < m.num_frames && !animated; ++t)
        animated = (m.translation(t, j) - offset).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + offset.cwiseAbs().maxCoeff());
      BvhChannelLayout& layout = bvh.channels[static_cast<size_t>(j)];
      if (animated) layout = kPosition;
      layout.insert(layout.end(), kRotation.begin(), kRotation.end());
    }
  }

  std::vector<RotationPlan> plans;
  plans.reserve(static_cast<size_t>(num_joints));
  for (const BvhChannelLayout& layout : bvh.channels) plans.push_back(plan_rotation(layout));

  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  bvh.values.resize(static_cast<size_t>(m.num_frames) * num_channels);
  std::vector<Eigen::Vector3d> previous(static_cast<size_t>(num_joints), Eigen::Vector3d::Zero());
  for (int t = 0; t < m.num_frames; ++t) {
    double* row = bvh.values.data() + static_cast<size_t>(t) * num_channels;
    size_t column = 0;
    for (int j = 0; j < num_joints; ++j) {
      const RotationPlan& plan = plans[static_cast<size_t>(j)];
      Eigen::Vector3d angles = Eigen::Vector3d::Zero();  // radians, in plan.order
      if (plan.num_rotation_channels > 0) {
        const Eigen::Quaterniond q = m.rotation(t, j).normalized();
        angles = euler_from_quat(q, plan.order);
        if (t > 0) {
          const Eigen::Vector3d& prev = previous[static_cast<size_t>(j)];
          if (plan.num_rotation_channels == 3 && std::abs(std::sin(angles[1])) >= 1.0 - 1e-12) {
            // Gimbal lock: only a combination of the outer angles is determined. Keep the last
            // angle from the previous frame and solve for the first, instead of zeroing it.
            const int last_axis = euler_axis(plan.order, 2);
            angles = euler_from_quat(q * quat_about_axis(last_axis, -prev[2]), plan.order);
            angles[2] = prev[2];
          }
          // The other Euler triple of the same rotation; only exact when all three angles are kept.
          Eigen::Vector3d candidates[2] = {angles, Eigen::Vector3d(angles[0] + kPi, kPi - angles[1], angles[2] + kPi)};
          const int num_candidates = plan.num_rotation_channels == 3 ? 2 : 1;
          double best = std::numeric_limits<double>::infinity();
          for (int k = 0; k < num_candidates; ++k) {
            Eigen::Vector3d& c = candidates[k];
            for (int i = 0; i < 3; ++i) c[i] = unwrap_near(c[i], prev[i]);
            const double distance = (c - prev).squaredNorm();
            if (distance < best) {
              best = distance;
              angles = c;
            }
          }
        }
        previous[static_cast<size_t>(j)] = angles;
      }
      const Eigen::Vector3d& translation = m.translation(t, j);
      int rotation_index = 0;
      for (BvhChannel c : bvh.channels[static_cast<size_t>(j)]) {
        // Rotation channels take the plan's angles in order (the order starts with their axes).
        row[column++] = is_rotation(c) ? angles[rotation_index++] * kDegPerRad : translation[channel_axis(c)];
      }
    }
  }
  return bvh;
}

}  // namespace mosyn::io
