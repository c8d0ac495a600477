// "CONTENT:STYLE" patterns over a dataset's label vocabularies ("*" = any label, unlabelled clips
// included), shared by the options that single out labels: the trainer's label_weights and
// MoGlow's lift_off_labels and heel_label_weights.
#pragma once

#include <string>
#include <vector>

namespace mosyn::nn {

// A label wildcard of LabelPattern: any content or style, unlabelled (-1) included.
constexpr int kAnyLabel = -2;

// One pattern resolved against a dataset's vocabularies.
struct LabelPattern {
  int content = kAnyLabel;  // index into the content vocabulary, or kAnyLabel
  int style = kAnyLabel;    // index into the style vocabulary, or kAnyLabel
  std::string key;          // as given ("run:elderly"), for messages
};

// The problem with a pattern's form, "" if none: `what` (the option, e.g. "label_weights") names
// it in the message; a pattern needs exactly one ':' ("run:elderly", "run:*", "*:*").
std::string label_pattern_problem(const std::string& key, const std::string& what);

// The problem with one "CONTENT:STYLE": factor entry, "" if none: the key's form (as above) or a
// factor that is not finite and in (0, 1000] ([0, 1000] with zero_allowed).
std::string label_factor_problem(const std::string& key, double factor, const std::string& what, bool zero_allowed);

// Resolves `key` against the vocabularies. Throws mosyn::Error, starting with `what`, for a
// malformed key or a label the vocabulary lacks (naming the known ones).
LabelPattern resolve_label_pattern(const std::string& key, const std::vector<std::string>& content_labels,
                                   const std::vector<std::string>& style_labels, const std::string& what);

// Whether a clip of labels (content, style) (-1 = none) matches the pattern.
inline bool label_pattern_matches(const LabelPattern& p, int content, int style) {
  return (p.content == kAnyLabel || content == p.content) && (p.style == kAnyLabel || style == p.style);
}

}  // namespace mosyn::nn
