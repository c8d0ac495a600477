// BVH reader: a single-pass tokenizer and parser over the whole text (see io/bvh.h for the
// accepted syntax and what is rejected).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <unordered_set>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/bvh.h"

namespace mosyn::io {
namespace {

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


}  // namespace

BvhFile parse_bvh(const std::string& text, const std::string& file_name_for_errors) {
  return BvhParser(text, file_name_for_errors).parse();
}

BvhFile read_bvh(const std::string& path) { return parse_bvh(read_file(path), path); }

}  // namespace mosyn::io
