// Integers read from JSON without undefined behaviour. nlohmann's get<int>() of a floating-point
// value is a plain cast, undefined when the value lies outside the integer's range (a fuzzed
// "-1.2e63" where a count is expected). json_get<T> checks first: integers must lie in T's range
// and floating-point values must be whole numbers in it; anything else throws
// nlohmann::json::out_of_range (or type_error for a non-number), which callers already turn into
// errors naming the file.
#pragma once

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <vector>

namespace mosyn::io {

namespace json_detail {

template <typename T>
constexpr bool kCheckedInteger = std::is_integral_v<T> && !std::is_same_v<T, bool>;

template <typename T>
struct IsIntegerVector : std::false_type {};
template <typename E, typename A>
struct IsIntegerVector<std::vector<E, A>> : std::bool_constant<kCheckedInteger<E>> {};

template <typename T>
void check_integer(const nlohmann::json& j) {
  if (!j.is_number()) return;  // get<T>() reports the type error itself
  bool fits;
  if (j.is_number_float()) {
    // [min, max + 1): both bounds are powers of two (or 0), exact as doubles.
    const double v = j.get<double>();
    fits = std::isfinite(v) && std::floor(v) == v && v >= static_cast<double>(std::numeric_limits<T>::min()) &&
           v < std::ldexp(1.0, std::numeric_limits<T>::digits);
  } else if (j.is_number_unsigned()) {
    fits = j.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max());
  } else {
    const std::int64_t v = j.get<std::int64_t>();
    fits = v < 0 ? std::is_signed_v<T> && v >= static_cast<std::int64_t>(std::numeric_limits<T>::min())
                 : static_cast<std::uint64_t>(v) <= static_cast<std::uint64_t>(std::numeric_limits<T>::max());
  }
  if (!fits)
    throw nlohmann::json::out_of_range::create(406, "number " + j.dump() + " is not an integer in the expected range",
                                               &j);
}

}  // namespace json_detail

// j.get<T>(), with integers (and arrays of them) checked as above.
template <typename T>
T json_get(const nlohmann::json& j) {
  if constexpr (json_detail::kCheckedInteger<T>) {
    json_detail::check_integer<T>(j);
  } else if constexpr (json_detail::IsIntegerVector<T>::value) {
    if (j.is_array())
      for (const auto& e : j) json_detail::check_integer<typename T::value_type>(e);
  }
  return j.template get<T>();
}

// j.value(key, fallback) with the same check.
template <typename T>
T json_value(const nlohmann::json& j, const char* key, T fallback) {
  return j.is_object() && j.contains(key) ? json_get<T>(j.at(key)) : fallback;
}

}  // namespace mosyn::io
