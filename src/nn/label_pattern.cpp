#include "nn/label_pattern.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace mosyn::nn {

namespace {

int label_index(const std::string& name, const std::vector<std::string>& vocabulary, const char* kind,
                const std::string& key, const std::string& what) {
  if (name == "*") return kAnyLabel;
  const auto it = std::find(vocabulary.begin(), vocabulary.end(), name);
  if (it != vocabulary.end()) return static_cast<int>(it - vocabulary.begin());
  std::string known;
  for (const std::string& v : vocabulary) known += (known.empty() ? "" : ", ") + v;
  throw Error(what + ": '" + key + "': unknown " + kind + " label '" + name + "' (known: " +
              (known.empty() ? "none, the dataset is unlabelled" : known) + ", or *)");
}

}  // namespace

std::string label_pattern_problem(const std::string& key, const std::string& what) {
  const size_t colon = key.find(':');
  if (colon == std::string::npos || key.find(':', colon + 1) != std::string::npos)
    return what + ": '" + key + "': expected CONTENT:STYLE (either may be *), e.g. run:elderly";
  return "";
}

std::string label_factor_problem(const std::string& key, double factor, const std::string& what, bool zero_allowed) {
  if (std::string problem = label_pattern_problem(key, what); !problem.empty()) return problem;
  if (!(std::isfinite(factor) && (zero_allowed ? factor >= 0 : factor > 0) && factor <= 1000))
    return what + ": '" + key + "': the factor must lie in " + (zero_allowed ? "[0" : "(0") + ", 1000], got " +
           std::to_string(factor);
  return "";
}

LabelPattern resolve_label_pattern(const std::string& key, const std::vector<std::string>& content_labels,
                                   const std::vector<std::string>& style_labels, const std::string& what) {
  if (const std::string problem = label_pattern_problem(key, what); !problem.empty()) throw Error(problem);
  const size_t colon = key.find(':');
  LabelPattern p;
  p.content = label_index(key.substr(0, colon), content_labels, "content", key, what);
  p.style = label_index(key.substr(colon + 1), style_labels, "style", key, what);
  p.key = key;
  return p;
}

}  // namespace mosyn::nn
