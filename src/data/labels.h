// Source folders of BVH files and their content/style labels.
//
// Recognised layouts (detected by list_source):
//   Bandai-Namco  <dir>/cfg/content_label.txt, <dir>/cfg/style_label.txt (one label name per
//                 line, line index = label id, e.g. "dataset-2_walk"), <dir>/data/*.bvh each with
//                 a sibling <name>.json {"content": id, "style": id}. Names lose their
//                 "dataset-N_" prefix ("dataset-2_walk" -> "walk") so datasets 1 and 2 share one
//                 vocabulary when combined.
//   CMU           <dir>/index.csv with a header naming at least the columns "file" (relative to
//                 <dir>) and "action" (the content label); no styles. Further columns (subject,
//                 trial, description, frames, fps, seconds) are ignored. Fields may be quoted.
//   plain         any other folder: every *.bvh below it (recursively), unlabelled.
// Malformed label files throw mosyn::ParseError with file:line; missing files mosyn::Error.
#pragma once

#include <string>
#include <vector>

namespace mosyn::data {

enum class SourceLayout { kBandaiNamco, kCmu, kPlain };
const char* to_string(SourceLayout layout);  // "bandai-namco", "cmu", "plain"

struct SourceFile {
  std::string path;      // full path of the BVH file
  std::string relative;  // path relative to the source folder, '/' separated
  std::string content;   // content label name ("" when unlabelled)
  std::string style;     // style label name ("" when unlabelled)
};

struct SourceListing {
  std::string dir;
  SourceLayout layout = SourceLayout::kPlain;
  std::vector<std::string> content_labels;  // vocabulary in file order (prefix stripped)
  std::vector<std::string> style_labels;
  std::vector<SourceFile> files;            // sorted by relative path
};

// "dataset-2_walk" -> "walk"; names without a "dataset-<digits>_" prefix are returned as is.
std::string strip_dataset_prefix(const std::string& label);

// Lists a source folder (layout detected as above). Throws mosyn::Error when dir is not a
// directory or holds no BVH file, ParseError for malformed label files (file:line), and Error
// naming the file when a Bandai-Namco BVH has no label JSON or a CMU index row names a file
// that does not exist.
SourceListing list_source(const std::string& dir);

// Keeps only files whose content is in contents (when non-empty) and whose style is in styles
// (when non-empty); names compare after strip_dataset_prefix. Throws mosyn::Error when a filter
// name is in neither vocabulary (listing the known names) or when filtering an unlabelled source.
void filter_source(SourceListing* listing, const std::vector<std::string>& contents,
                   const std::vector<std::string>& styles);

// The label a mirror image carries: "left" and "right" swapped as whole words between '-', '_'
// or the ends ("walk-turn-left" -> "walk-turn-right", "wave-left-hand" -> "wave-right-hand"),
// "" unchanged. The caller keeps the original when the swapped name is not in its vocabulary.
std::string mirrored_label(const std::string& label);

}  // namespace mosyn::data
