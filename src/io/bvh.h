// Biovision Hierarchy (BVH) motion-capture files: parsing, writing, and conversion to and from
// mosyn::Clip.
//
// Conventions:
// - Joint order is the file's depth-first order; BvhFile::skeleton, BvhFile::channels and the
//   columns of BvhFile::values all follow it. End Sites are kept in Skeleton::end_sites.
// - Lengths stay in the file's units. io never guesses units or the up axis: a parsed skeleton
//   always has meters_per_unit = 1 and up_axis = 1 (+Y); the data layer sets them.
// - Angles in the file are degrees. A joint's rotation channels, in file order c1 c2 c3, mean
//   R = R_c1(a1) * R_c2(a2) * R_c3(a3) (e.g. "Zrotation Xrotation Yrotation" is EulerOrder::kZXY).
//   Any subset of axes, in any order, mixed per joint, is accepted.
// - Position channels replace the matching component of the joint's OFFSET (for the root this is
//   its world position); components without a channel keep the OFFSET value.
// - "Frames: 0" is valid: a skeleton with no motion (num_frames = 0, values empty).
//
// Accepted syntax: keywords in any letter case, LF or CRLF line ends, spaces or tabs, a UTF-8 BOM,
// braces on their own line or not, "End Site" blocks, "Frames:" / "Frame Time:" with or without
// spaces or tabs after the colon, numbers in plain or scientific notation (leading '+' or '.'
// allowed), trailing whitespace and blank lines. Motion data is normally one frame per line; a
// frame may also wrap over several lines as long as the total number of values is
// Frames x (sum of CHANNELS).
//
// Rejected with mosyn::ParseError ("file:line: message"): missing HIERARCHY/ROOT/MOTION, unbalanced
// braces, unknown keywords or channel names, CHANNELS counts that disagree with the names or
// exceed 6, repeated channels in one joint, duplicate joint names, more than one ROOT, nesting
// deeper than kBvhMaxDepth or more than kBvhMaxJoints joints, non-numeric, NaN or infinite
// numbers, negative or absurd Frames, non-positive or non-finite Frame Time, data lines with too
// few or too many values, truncated files. Memory use is bounded by the input size.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::io {

constexpr int kBvhMaxDepth = 1024;    // deepest allowed joint nesting
constexpr int kBvhMaxJoints = 10000;  // most joints in one file

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

// "Xposition", ..., "Zrotation" (the BVH spelling).
const char* to_string(BvhChannel channel);
// Axis of a channel: 0 = X, 1 = Y, 2 = Z.
int channel_axis(BvhChannel channel);
bool is_rotation(BvhChannel channel);

// One joint's channels, in file order.
using BvhChannelLayout = std::vector<BvhChannel>;

// A BVH file as stored: hierarchy, channel layout and the raw motion table.
struct BvhFile {
  Skeleton skeleton;                      // names, parents, OFFSETs, End Sites; units as in the file
  std::vector<BvhChannelLayout> channels;  // [J] per joint, in file order
  double frame_time_s = 1.0 / 30.0;       // seconds per frame, > 0
  int num_frames = 0;
  // [num_frames, num_channels()] row-major, exactly as in the file: positions in skeleton units,
  // rotations in degrees.
  std::vector<double> values;

  // Sum of all joints' channel counts (the number of values per frame).
  int num_channels() const;
  // Column in a frame row of the first channel of joint j.
  int first_channel(int j) const;
};

// Parses BVH text. file_name_for_errors is used only in error messages. Throws ParseError.
BvhFile parse_bvh(const std::string& text, const std::string& file_name_for_errors);

// Reads and parses a BVH file. Throws mosyn::Error naming the path when it cannot be read and
// ParseError (file:line) when its content is malformed.
BvhFile read_bvh(const std::string& path);

// BVH text: tab-indented hierarchy, "Frames:", "Frame Time:" and one frame per line. Numbers are
// written with significant_digits significant digits (9 is ample for degrees and lengths; 17 is
// exact); the frame time is written exactly. Joints must be in depth-first pre-order (each
// joint's subtree follows it contiguously, as parse_bvh produces); a joint's End Sites are written
// before its child joints. Throws mosyn::Error when the arrays disagree in size, a value is not
// finite, the joint order is not a pre-order, or a joint name would not read back (empty, braces,
// or whitespace other than single interior spaces).
std::string format_bvh(const BvhFile& bvh, int significant_digits = 9);

// format_bvh written atomically (io/atomic_file.h).
void write_bvh(const std::string& path, const BvhFile& bvh, int significant_digits = 9);

// A clip from a BVH file: local rotations from the rotation channels (identity for joints
// without any), local translations from the position channels and OFFSETs (see the conventions
// above), fps = 1 / frame_time_s. Quaternions are normalised and kept in the same hemisphere as
// the previous frame's, so sequences are continuous. Throws mosyn::Error when the BvhFile is
// inconsistent.
Clip to_clip(const BvhFile& bvh);

// A BVH file for a clip. Euler angles are chosen continuous over time: at each frame, of the two
// equivalent Euler solutions, each angle unwrapped by multiples of 360 degrees, the one closest
// to the previous frame's is used, so angles never flip by 360 degrees or switch solution for a
// frame: between two frames they move by at most sqrt(2) times the angle the joint turns over the
// cosine of the middle angle (what following the rotation continuously takes). At gimbal lock
// (middle angle +-90 degrees) the change of the determined sum or difference of the outer angles
// is split evenly between them. Frame 0 takes the source's own angles where the template holds
// this very motion (as `mosyn convert` passes it), else the principal solution (middle angle
// within +-90 degrees). Where a joint turns more than 45 degrees in one frame (a T-pose first
// frame, a capture glitch) the angles cannot follow and jump anyway; there each angle changes as
// the source's does (within +-180 degrees), else the principal solution is taken, unwrapped, so
// a written file has no jump its source lacks (01_01.bvh's left forearm keeps 0 -> -36.8, not
// 0 -> -143.2 on the other branch for the whole take). Checked on every shared BVH file
// (tests/io/test_bvh_real_data.cpp). Source files themselves need not be continuous (the CMU
// subset's 05_08.bvh flips a hand joint for 9 frames; written back it turns the short way).
//
// Without a template the layout is CMU-like: the root has "Xposition Yposition Zposition
// Zrotation Yrotation Xrotation", every other joint "Zrotation Yrotation Xrotation", plus
// position channels on any non-root joint whose translation differs from its offset in some frame
// (so nothing is lost). With layout_template (for example the BvhFile the clip came from), its
// channel layout is reused joint by joint, so a Bandai-Namco file (6 channels, ZXY, every joint)
// keeps its layout; the template must have the same joint names in the same order. Joints whose
// template layout lacks position channels lose animated translation, and joints with fewer than
// three rotation channels get the closest rotation those axes can express (both lossy by the
// template's choice).
//
// Throws mosyn::Error when the clip is inconsistent, fps is not positive, or the template does
// not match the skeleton.
BvhFile from_clip(const Clip& clip, const BvhFile* layout_template = nullptr);

}  // namespace mosyn::io
