// One declaration per option for a model family's hyper-parameters: its JSON key, the struct
// member it sets, a one-line doc and an optional check. The list both reads a (partial) JSON config
// and writes the resolved one, so a family's Options::from_json / to_json are a few lines:
//
//   const OptionFields<RvaeOptions>& fields() {
//     static const auto f = OptionFields<RvaeOptions>("rvae")
//                               .field("latent", &RvaeOptions::latent, "latent size", at_least(1))
//                               .field("labels", &RvaeOptions::labels, "labels as conditions")
//                               .written_if([](const RvaeOptions& o) { return o.labels; });
//     return f;
//   }
//   RvaeOptions o;
//   fields().read(config, &o);  // type errors and unknown keys
//   fields().check(o);          // value checks, once, in declaration order
//
// The declaring calls (field, written_if, rule, ignore, include) chain on a temporary, so a list is built in
// one expression and then only read (one static list per family).
// Supported member types: int, std::uint64_t, double, bool, std::string, std::vector<int>,
// std::vector<double>, std::vector<std::string>, std::map<std::string, double>, nlohmann::json (an
// object kept as it is).
// Errors are mosyn::Error "<family> config: ...". Header-only; no LibTorch.
#pragma once

#include <climits>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <map>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.h"

namespace mosyn::nn {

// A value check of one option. fn(key, value) returns "" when the value is fine, else the message
// after "<family> config: " (e.g. "kernel must be odd and >= 1"). type_message, when not empty,
// replaces the default type error after "<family> config: <key> " (used by one_of).
template <class T>
struct FieldCheck {
  std::function<std::string(const std::string& key, const T& value)> fn;
  std::string type_message;
};

namespace options_detail {

// How each supported type is recognised in JSON and named in the type error.
template <class T>
struct JsonType;
template <>
struct JsonType<int> {
  // An integer that fits int: a larger one would wrap on conversion (e.g. "hidden": 10000000000
  // into a positive 1410065408 that passes every range check and allocates without bound).
  static bool is(const nlohmann::json& j) {
    if (j.is_number_unsigned()) return j.get<std::uint64_t>() <= static_cast<std::uint64_t>(INT_MAX);
    return j.is_number_integer() && j.get<std::int64_t>() >= INT_MIN && j.get<std::int64_t>() <= INT_MAX;
  }
  static const char* error() { return "must be an integer"; }
};
template <>
struct JsonType<std::uint64_t> {  // seeds: any non-negative integer
  static bool is(const nlohmann::json& j) {
    return j.is_number_unsigned() || (j.is_number_integer() && j.get<std::int64_t>() >= 0);
  }
  static const char* error() { return "must be a non-negative integer"; }
};
template <>
struct JsonType<nlohmann::json> {  // a nested config kept as it is (e.g. a training's model overrides)
  static bool is(const nlohmann::json& j) { return j.is_object(); }
  static const char* error() { return "must be a JSON object"; }
};
template <>
struct JsonType<double> {
  static bool is(const nlohmann::json& j) { return j.is_number(); }
  static const char* error() { return "must be a number"; }
};
template <>
struct JsonType<bool> {
  static bool is(const nlohmann::json& j) { return j.is_boolean(); }
  static const char* error() { return "must be true or false"; }
};
template <>
struct JsonType<std::string> {
  static bool is(const nlohmann::json& j) { return j.is_string(); }
  static const char* error() { return "must be a string"; }
};
template <class E>
struct JsonType<std::vector<E>> {
  static bool is(const nlohmann::json& j) {
    if (!j.is_array()) return false;
    for (const auto& e : j)
      if (!JsonType<E>::is(e)) return false;
    return true;
  }
  static const char* error() {
    if constexpr (std::is_same_v<E, std::string>) return "must be an array of strings";
    return std::is_same_v<E, int> ? "must be an array of integers" : "must be an array of numbers";
  }
};

template <>
struct JsonType<std::map<std::string, double>> {
  static bool is(const nlohmann::json& j) {
    if (!j.is_object()) return false;
    for (const auto& item : j.items())
      if (!item.value().is_number()) return false;
    return true;
  }
  static const char* error() { return "must be an object of numbers"; }
};

// A number as the messages write it: 1, 0.5, 1000.
inline std::string number_text(double v) {
  std::string s = nlohmann::json(v).dump();
  if (s.size() > 2 && s.compare(s.size() - 2, 2, ".0") == 0) s.resize(s.size() - 2);
  return s;
}

}  // namespace options_detail

// value >= lo: "<key> must be >= lo".
template <class T>
FieldCheck<T> at_least(T lo) {
  return {[lo](const std::string& key, const T& v) {
            return v >= lo ? std::string() : key + " must be >= " + options_detail::number_text(lo);
          },
          ""};
}

namespace options_detail {

// A value in the interval from lo to hi, each end closed or open: "<key> must be in [lo, hi)" etc.
inline FieldCheck<double> interval(double lo, bool lo_closed, double hi, bool hi_closed) {
  return {[=](const std::string& key, const double& v) {
            const bool ok = (lo_closed ? v >= lo : v > lo) && (hi_closed ? v <= hi : v < hi);
            return ok ? std::string()
                      : key + " must be in " + (lo_closed ? "[" : "(") + number_text(lo) + ", " + number_text(hi) +
                            (hi_closed ? "]" : ")");
          },
          ""};
}

}  // namespace options_detail

// lo <= value <= hi (or < hi when !hi_closed): "<key> must be in [lo, hi]" / "[lo, hi)".
inline FieldCheck<double> in_range(double lo, double hi, bool hi_closed = true) {
  return options_detail::interval(lo, true, hi, hi_closed);
}

// lo < value <= hi: "<key> must be in (lo, hi]" (a weight or a threshold that must not be lo).
inline FieldCheck<double> above_up_to(double lo, double hi) { return options_detail::interval(lo, false, hi, true); }

// An odd integer >= lo (kernel widths with 'same' padding): "<key> must be odd and >= lo".
inline FieldCheck<int> odd_at_least(int lo) {
  return {[lo](const std::string& key, const int& v) {
            return v >= lo && v % 2 != 0 ? std::string() : key + " must be odd and >= " + std::to_string(lo);
          },
          ""};
}

// One of the given strings: '<key> must be "a" or "b", not "x"' (the type error without ", not").
inline FieldCheck<std::string> one_of(std::vector<std::string> allowed) {
  std::string list;
  for (size_t i = 0; i < allowed.size(); ++i)
    list += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ") + ("\"" + allowed[i] + "\"");
  FieldCheck<std::string> c;
  c.type_message = "must be " + list;
  c.fn = [allowed, list](const std::string& key, const std::string& v) {
    for (const auto& a : allowed)
      if (v == a) return std::string();
    return key + " must be " + list + ", not \"" + v + "\"";
  };
  return c;
}

// Every entry >= lo, checked while reading (as part of the type): "'<key>' entries must be >= lo".
template <class E>
FieldCheck<std::vector<E>> entries_at_least(E lo) {
  return {[lo](const std::string& key, const std::vector<E>& v) {
            for (const E& e : v)
              if (!(e >= lo)) return "'" + key + "' entries must be >= " + options_detail::number_text(lo);
            return std::string();
          },
          ""};
}

template <class Options>
class OptionFields {
 public:
  // family names the errors: "<family> config: ...". The key "family" is always ignored (run
  // configs may carry it).
  explicit OptionFields(std::string family) : family_(std::move(family)) { ignored_.insert("family"); }

  // Declares the option `key` stored in `member`. `check` runs in check() (after every key was
  // read), in declaration order with the rules. Returns *this for chaining.
  template <class T>
  OptionFields field(const std::string& key, T Options::*member, std::string doc, FieldCheck<T> check = {}) && {
    add(key, member, std::move(doc), std::move(check), false);
    return std::move(*this);
  }
  // As field, but the check runs while reading, as a type error would (e.g. entries_at_least).
  template <class T>
  OptionFields field_checked_on_read(const std::string& key, T Options::*member, std::string doc,
                                     FieldCheck<T> check) && {
    add(key, member, std::move(doc), std::move(check), true);
    return std::move(*this);
  }
  // to_json writes the last declared field only when pred holds (keys absent from configs of runs
  // made before the option existed stay absent, keeping them byte-identical).
  OptionFields written_if(std::function<bool(const Options&)> pred) && {
    entries_.back().written = std::move(pred);
    return std::move(*this);
  }
  // A check over several options (e.g. matching list lengths), run in declaration order: returns
  // "" when fine, else the message after "<family> config: ".
  OptionFields rule(std::function<std::string(const Options&)> fn) && {
    Entry e;
    e.check = std::move(fn);
    entries_.push_back(std::move(e));
    return std::move(*this);
  }
  // A key that read() accepts and skips (the family reads it itself, e.g. "preset").
  OptionFields ignore(const std::string& key) && {
    ignored_.insert(key);
    return std::move(*this);
  }
  // Declares every field and rule of `sub` (a list over the struct Sub) as this list's own, reading
  // and writing the member `member` of Options: options shared by several families (e.g. the foot
  // objectives, nn/objectives/foot_objectives.h) live in one struct with one field list, and each
  // family's config takes their keys at its top level, its errors naming the family. Keys must not
  // repeat the family's own.
  template <class Sub>
  OptionFields include(Sub Options::*member, const OptionFields<Sub>& sub) && {
    for (const auto& s : sub.entries_) {
      Entry e;
      e.key = s.key;
      e.doc = s.doc;
      if (s.read)
        e.read = [member, r = s.read](const nlohmann::json& v, Options* out, const std::string& family) {
          r(v, &(out->*member), family);
        };
      if (s.write) e.write = [member, w = s.write](const Options& o, nlohmann::json* j) { w(o.*member, j); };
      if (s.check) e.check = [member, c = s.check](const Options& o) { return c(o.*member); };
      if (s.written) e.written = [member, w = s.written](const Options& o) { return w(o.*member); };
      entries_.push_back(std::move(e));
    }
    return std::move(*this);
  }

  // Reads every key of config into *out (other members keep their values). Throws mosyn::Error
  // "<family> config must be a JSON object", "... unknown key 'k'" or the key's type error.
  void read(const nlohmann::json& config, Options* out) const {
    if (!config.is_object()) throw Error(family_ + " config must be a JSON object");
    for (auto it = config.begin(); it != config.end(); ++it) {
      if (ignored_.count(it.key())) continue;
      const Entry* e = find(it.key());
      if (!e) throw Error(family_ + " config: unknown key '" + it.key() + "'");
      e->read(it.value(), out, family_);
    }
  }
  // Reads the one key `key` of config (present and declared) into *out.
  void read_key(const nlohmann::json& config, const std::string& key, Options* out) const {
    find(key)->read(config.at(key), out, family_);
  }

  // Runs the value checks and rules in declaration order; throws mosyn::Error on the first failure.
  void check(const Options& o) const {
    for (const auto& e : entries_) {
      if (!e.check) continue;
      const std::string problem = e.check(o);
      if (!problem.empty()) throw Error(family_ + " config: " + problem);
    }
  }

  // The options as JSON: every declared key (except those whose written_if is false).
  nlohmann::json write(const Options& o) const {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& e : entries_)
      if (!e.key.empty() && (!e.written || e.written(o))) e.write(o, &j);
    return j;
  }

  // (key, doc) of every declared option, in declaration order (for help texts).
  std::vector<std::pair<std::string, std::string>> docs() const {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& e : entries_)
      if (!e.key.empty()) out.emplace_back(e.key, e.doc);
    return out;
  }

 private:
  template <class>
  friend class OptionFields;  // include() reads another list's entries
  struct Entry {
    std::string key, doc;  // key empty for a rule
    // family: the list that reads (an including list's, so that its errors name it).
    std::function<void(const nlohmann::json&, Options*, const std::string& family)> read;
    std::function<void(const Options&, nlohmann::json*)> write;
    std::function<std::string(const Options&)> check;
    std::function<bool(const Options&)> written;
  };

  template <class T>
  void add(const std::string& key, T Options::*member, std::string doc, FieldCheck<T> check, bool on_read) {
    using J = options_detail::JsonType<T>;
    Entry e;
    e.key = key;
    e.doc = std::move(doc);
    const std::string type_error = check.type_message.empty() ? "'" + key + "' " + J::error()
                                                              : key + " " + check.type_message;
    auto fn = check.fn;
    e.read = [=](const nlohmann::json& v, Options* out, const std::string& family) {
      if (!J::is(v)) throw Error(family + " config: " + type_error);
      T value = v.get<T>();
      if (on_read && fn) {
        const std::string problem = fn(key, value);
        if (!problem.empty()) throw Error(family + " config: " + problem);
      }
      out->*member = std::move(value);
    };
    e.write = [key, member](const Options& o, nlohmann::json* j) { (*j)[key] = o.*member; };
    if (fn && !on_read) e.check = [key, member, fn](const Options& o) { return fn(key, o.*member); };
    entries_.push_back(std::move(e));
  }

  const Entry* find(const std::string& key) const {
    for (const auto& e : entries_)
      if (e.key == key) return &e;
    return nullptr;
  }

  std::string family_;
  std::set<std::string> ignored_;
  std::vector<Entry> entries_;
};

}  // namespace mosyn::nn
