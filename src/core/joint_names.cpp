#include "core/joint_names.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include "core/error.h"

namespace mosyn {
namespace {

// Words of a joint name: split at non-letters (separators, digits) and camelCase boundaries
// ("LHipJoint" -> L, Hip, Joint), lowercased.
std::vector<std::string> words_of(const std::string& name) {
  std::vector<std::string> words;
  std::string word;
  auto flush = [&] {
    if (!word.empty()) words.push_back(word);
    word.clear();
  };
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (!std::isalpha(c)) {
      flush();
      continue;
    }
    const bool upper = std::isupper(c);
    const bool prev_lower = i > 0 && std::islower(static_cast<unsigned char>(name[i - 1]));
    const bool next_lower = i + 1 < name.size() && std::islower(static_cast<unsigned char>(name[i + 1]));
    const bool prev_upper = i > 0 && std::isupper(static_cast<unsigned char>(name[i - 1]));
    if (upper && (prev_lower || (prev_upper && next_lower))) flush();
    word += static_cast<char>(std::tolower(c));
  }
  flush();
  return words;
}

// Words that name no part and no side: rig prefixes and filler ("mixamorig:", "DEF-", "joint_").
bool is_filler(const std::string& w) {
  static const std::set<std::string> kFiller = {"mixamorig", "def", "org", "mch", "bip", "biped", "joint",
                                                "jnt", "bone", "bn", "jt", "sk", "skel", "char"};
  return kFiller.count(w) > 0;
}

// Words that make a joint no part at all: helpers, ends and fingers.
bool is_excluded(const std::string& w) {
  static const std::set<std::string> kExcluded = {"twist", "roll", "end", "nub", "tip", "ik", "pole", "target",
                                                  "ctrl", "thumb", "index", "middle", "ring", "pinky", "finger",
                                                  "fingers", "little", "helper", "corrective", "site", "top"};
  return kExcluded.count(w) > 0;
}

BodyPart part_of_key(const std::string& key, BodySide side) {
  const bool sided = side != BodySide::kCentre;
  if (!sided) {
    if (key == "hips" || key == "hip" || key == "pelvis") return BodyPart::kHips;
    if (key.rfind("spine", 0) == 0 || key == "chest" || key == "upperchest" || key == "lowerback" || key == "back" ||
        key == "torso" || key == "abdomen")
      return BodyPart::kSpine;
    if (key.rfind("neck", 0) == 0) return BodyPart::kNeck;
    if (key == "head") return BodyPart::kHead;
    return BodyPart::kNone;
  }
  static const std::map<std::string, BodyPart> kSided = {
      {"shoulder", BodyPart::kShoulder}, {"clavicle", BodyPart::kShoulder}, {"collar", BodyPart::kShoulder},
      {"collarbone", BodyPart::kShoulder}, {"arm", BodyPart::kUpperArm},    {"upperarm", BodyPart::kUpperArm},
      {"uparm", BodyPart::kUpperArm},      {"forearm", BodyPart::kForearm}, {"lowerarm", BodyPart::kForearm},
      {"loarm", BodyPart::kForearm},       {"elbow", BodyPart::kForearm},   {"hand", BodyPart::kHand},
      {"wrist", BodyPart::kHand},          {"upleg", BodyPart::kThigh},     {"upperleg", BodyPart::kThigh},
      {"thigh", BodyPart::kThigh},         {"femur", BodyPart::kThigh},     {"leg", BodyPart::kShin},
      {"lowerleg", BodyPart::kShin},       {"loleg", BodyPart::kShin},      {"shin", BodyPart::kShin},
      {"calf", BodyPart::kShin},           {"knee", BodyPart::kShin},       {"foot", BodyPart::kFoot},
      {"ankle", BodyPart::kFoot},          {"toe", BodyPart::kToe},         {"toes", BodyPart::kToe},
      {"toebase", BodyPart::kToe},         {"ball", BodyPart::kToe}};
  const auto it = kSided.find(key);
  return it == kSided.end() ? BodyPart::kNone : it->second;
}

bool is_chain(BodyPart part) { return part == BodyPart::kSpine || part == BodyPart::kNeck; }

// Joint indices of one chain part, root to tip (skeleton order is depth-first).
std::vector<int> chain_of(const std::vector<JointPart>& parts, BodyPart part) {
  std::vector<int> out;
  for (size_t j = 0; j < parts.size(); ++j)
    if (parts[j].part == part) out.push_back(static_cast<int>(j));
  return out;
}

// Pairs the joints of two chains by position along them: every joint of the shorter chain gets
// the joint of the longer one at the nearest fraction of its length; the rest stay unmatched.
void match_chain(const std::vector<int>& source, const std::vector<int>& target, std::vector<int>* match) {
  if (source.empty() || target.empty()) return;
  const size_t n = source.size(), m = target.size();
  auto at = [](size_t i, size_t from, size_t to) {
    return from <= 1 ? size_t{0} : static_cast<size_t>(std::lround(double(i) / double(from - 1) * double(to - 1)));
  };
  if (m >= n) {
    for (size_t i = 0; i < n; ++i) (*match)[target[at(i, n, m)]] = source[i];
  } else {
    for (size_t i = 0; i < m; ++i) (*match)[target[i]] = source[at(i, m, n)];
  }
}

std::vector<JointPart> parts_of(const Skeleton& skeleton) {
  std::vector<JointPart> parts;
  for (const std::string& name : skeleton.joint_names) parts.push_back(classify_joint_name(name));
  return parts;
}

// Name match of the parts (first joint of each (part, side) wins), chains by position.
std::vector<int> match_by_name(const std::vector<JointPart>& sp, const std::vector<JointPart>& tp) {
  std::vector<int> match(tp.size(), -1);
  std::map<std::pair<BodyPart, BodySide>, int> first_source;
  for (size_t j = 0; j < sp.size(); ++j)
    if (sp[j].part != BodyPart::kNone && !is_chain(sp[j].part))
      first_source.emplace(std::make_pair(sp[j].part, sp[j].side), static_cast<int>(j));
  std::set<std::pair<BodyPart, BodySide>> used;
  for (size_t j = 0; j < tp.size(); ++j) {
    const auto key = std::make_pair(tp[j].part, tp[j].side);
    const auto it = first_source.find(key);
    if (it == first_source.end() || !used.insert(key).second) continue;
    match[j] = it->second;
  }
  for (BodyPart chain : {BodyPart::kSpine, BodyPart::kNeck}) match_chain(chain_of(sp, chain), chain_of(tp, chain), &match);
  return match;
}

void apply_explicit(const Skeleton& source, const Skeleton& target, const std::map<std::string, std::string>& explicit_map,
                    std::vector<int>* match, std::vector<JointPart>* target_parts) {
  std::string unknown;
  for (const auto& [target_name, source_name] : explicit_map) {
    const int t = target.find(target_name), s = source.find(source_name);
    if (t < 0) unknown += (unknown.empty() ? "" : ", ") + std::string("rig joint '") + target_name + "'";
    if (s < 0) unknown += (unknown.empty() ? "" : ", ") + std::string("input joint '") + source_name + "'";
    if (t < 0 || s < 0) continue;
    for (int& m : *match)
      if (m == s) m = -1;  // the source joint now drives only the named target joint
    (*match)[t] = s;
    // The pair's part: the rig joint's name says it, else the input joint's.
    if ((*target_parts)[t].part == BodyPart::kNone) (*target_parts)[t] = classify_joint_name(source_name);
  }
  if (!unknown.empty()) throw Error("joint map names joints that do not exist: " + unknown);
}

const std::vector<JointPart>& required_parts() {
  static const std::vector<JointPart> kRequired = [] {
    std::vector<JointPart> r = {{BodyPart::kHips, BodySide::kCentre}, {BodyPart::kSpine, BodySide::kCentre}};
    for (BodySide side : {BodySide::kLeft, BodySide::kRight})
      for (BodyPart p : {BodyPart::kThigh, BodyPart::kShin, BodyPart::kFoot, BodyPart::kUpperArm, BodyPart::kForearm})
        r.push_back({p, side});
    return r;
  }();
  return kRequired;
}

// The error naming what could not be placed, or nothing when every required part is matched.
void check_required(const Skeleton& source, const Skeleton& target, const std::vector<int>& match,
                    const std::vector<JointPart>& source_parts, const std::vector<JointPart>& target_parts) {
  std::string missing_target, missing_source, unplaced;
  for (const JointPart& need : required_parts()) {
    bool in_source = false, placed = false;
    for (const JointPart& p : source_parts) in_source |= p.part == need.part && p.side == need.side;
    for (size_t j = 0; j < target_parts.size(); ++j)
      placed |= target_parts[j].part == need.part && target_parts[j].side == need.side && match[j] >= 0;
    if (placed) continue;
    if (!in_source) missing_source += (missing_source.empty() ? "" : ", ") + describe(need);
    missing_target += (missing_target.empty() ? "" : ", ") + describe(need);
  }
  if (missing_target.empty()) return;
  const std::string how = " (name the pairs in --map FILE.json: {\"rig joint\": \"input joint\", ...})";
  if (!missing_source.empty()) {
    std::string unknown;
    for (int j = 0; j < source.num_joints(); ++j)
      if (source_parts[j].part == BodyPart::kNone) unknown += (unknown.empty() ? "" : ", ") + source.joint_names[j];
    throw Error("cannot map the input onto the rig: no input joint is named as the " + missing_source +
                "; input joints not recognised: " + (unknown.empty() ? std::string("none") : unknown) + how);
  }
  for (int j = 0; j < target.num_joints(); ++j)
    if (match[j] < 0) unplaced += (unplaced.empty() ? "" : ", ") + target.joint_names[j];
  throw Error("cannot map the rig onto the input: no rig joint found for the " + missing_target +
              "; rig joints that could not be placed: " + (unplaced.empty() ? std::string("none") : unplaced) + how);
}

}  // namespace

JointPart classify_joint_name(const std::string& name) {
  JointPart out;
  std::string key;
  for (const std::string& w : words_of(name)) {
    if (is_excluded(w)) return JointPart{};
    if (is_filler(w)) continue;
    if (w == "l" || w == "left") {
      out.side = BodySide::kLeft;
    } else if (w == "r" || w == "right") {
      out.side = BodySide::kRight;
    } else {
      key += w;
    }
  }
  out.part = part_of_key(key, out.side);
  if (out.part == BodyPart::kNone) out.side = BodySide::kCentre;
  return out;
}

std::string describe(const JointPart& part) {
  static const std::map<BodyPart, std::string> kNames = {
      {BodyPart::kNone, "unknown part"}, {BodyPart::kHips, "hips"},         {BodyPart::kSpine, "spine"},
      {BodyPart::kNeck, "neck"},         {BodyPart::kHead, "head"},         {BodyPart::kShoulder, "shoulder"},
      {BodyPart::kUpperArm, "upper arm"}, {BodyPart::kForearm, "forearm"},  {BodyPart::kHand, "hand"},
      {BodyPart::kThigh, "thigh"},       {BodyPart::kShin, "shin"},         {BodyPart::kFoot, "foot"},
      {BodyPart::kToe, "toe"}};
  const std::string side = part.side == BodySide::kLeft ? "left " : part.side == BodySide::kRight ? "right " : "";
  return side + kNames.at(part.part);
}

std::vector<int> match_joints(const Skeleton& source, const Skeleton& target,
                              const std::map<std::string, std::string>& explicit_map) {
  const std::vector<JointPart> source_parts = parts_of(source);
  std::vector<JointPart> target_parts = parts_of(target);
  std::vector<int> match = match_by_name(source_parts, target_parts);
  apply_explicit(source, target, explicit_map, &match, &target_parts);
  check_required(source, target, match, source_parts, target_parts);
  return match;
}

}  // namespace mosyn
