#include "io/bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>
#include <unistd.h>

#include "core/error.h"
#include "core/rotation.h"
#include "io/atomic_file.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
using testing::expect_same_structure;

// Four joints: a 6-channel root (ZXY), a ZYX joint, an XYZ joint with an End Site, and a joint
// with a mixed subset of channels. 14 channels per frame.
const std::string kSmall =
    "HIERARCHY\n"
    "ROOT Hips\n"
    "{\n"
    "  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT Spine\n"
    "  {\n"
    "    OFFSET 0 10 0\n"
    "    CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "    JOINT Head\n"
    "    {\n"
    "      OFFSET 0 5 0.5\n"
    "      CHANNELS 3 Xrotation Yrotation Zrotation\n"
    "      End Site\n"
    "      {\n"
    "        OFFSET 0 2 0\n"
    "      }\n"
    "    }\n"
    "  }\n"
    "  JOINT Leg\n"
    "  {\n"
    "    OFFSET 1 -1 0\n"
    "    CHANNELS 2 Yrotation Xposition\n"
    "    End Site\n"
    "    {\n"
    "      OFFSET 0 -5 0\n"
    "    }\n"
    "  }\n"
    "}\n"
    "MOTION\n"
    "Frames: 2\n"
    "Frame Time: 0.0333333\n"
    "1 2 3 10 20 30 5 6 7 8 9 10 15 1.5\n"
    "-1 -2 -3 -10 -20 -30 -5 -6 -7 -8 -9 -10 -15 -1.5\n";

// Everything of kSmall up to and including "Frame Time:", so tests can supply their own data.
std::string small_header(int frames) {
  const size_t motion = kSmall.find("MOTION");
  return kSmall.substr(0, motion) + "MOTION\nFrames: " + std::to_string(frames) + "\nFrame Time: 0.0333333\n";
}

int line_of(const std::string& text, const std::string& needle) {
  const size_t pos = text.find(needle);
  EXPECT_NE(pos, std::string::npos) << needle;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
}

// Asserts that parsing throws a ParseError at the given line (0 = don't check) whose message
// contains the given text and names the file.
void expect_parse_error(const std::string& text, int line, const std::string& contains) {
  try {
    parse_bvh(text, "test.bvh");
    ADD_FAILURE() << "no error; expected '" << contains << "'";
  } catch (const ParseError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), "test.bvh");
    EXPECT_EQ(what.rfind("test.bvh:", 0), 0u) << what;
    if (line > 0) {
      EXPECT_EQ(e.line(), line) << what;
    }
    EXPECT_NE(what.find(contains), std::string::npos) << "message: " << what << "\nexpected: " << contains;
  }
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const size_t pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

fs::path make_temp_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("mosyn_test_io_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

Eigen::Quaterniond product(std::initializer_list<std::pair<int, double>> axis_degrees) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (const auto& [axis, deg] : axis_degrees) q = q * quat_about_axis(axis, deg * kPi / 180);
  return q;
}

// --- Parsing valid files ----------------------------------------------------------------------

TEST(Bvh, ParsesHierarchyChannelsAndValues) {
  const BvhFile bvh = parse_bvh(kSmall, "small.bvh");
  const Skeleton& sk = bvh.skeleton;
  ASSERT_EQ(sk.joint_names, (std::vector<std::string>{"Hips", "Spine", "Head", "Leg"}));
  EXPECT_EQ(sk.parents, (std::vector<int>{-1, 0, 1, 0}));
  EXPECT_EQ(sk.offsets[2], Eigen::Vector3d(0, 5, 0.5));
  EXPECT_EQ(sk.offsets[3], Eigen::Vector3d(1, -1, 0));
  ASSERT_EQ(sk.end_sites.size(), 2u);
  EXPECT_EQ(sk.end_sites[0].parent, 2);
  EXPECT_EQ(sk.end_sites[0].offset, Eigen::Vector3d(0, 2, 0));
  EXPECT_EQ(sk.end_sites[1].parent, 3);
  EXPECT_EQ(sk.meters_per_unit, 1.0);
  EXPECT_EQ(sk.up_axis, 1);
  EXPECT_NO_THROW(sk.validate());
  ASSERT_EQ(bvh.channels.size(), 4u);
  EXPECT_EQ(bvh.channels[0], (BvhChannelLayout{BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition,
                                               BvhChannel::kZrotation, BvhChannel::kXrotation, BvhChannel::kYrotation}));
  EXPECT_EQ(bvh.channels[3], (BvhChannelLayout{BvhChannel::kYrotation, BvhChannel::kXposition}));
  EXPECT_EQ(bvh.num_channels(), 14);
  EXPECT_EQ(bvh.first_channel(3), 12);
  EXPECT_EQ(bvh.num_frames, 2);
  EXPECT_DOUBLE_EQ(bvh.frame_time_s, 0.0333333);
  ASSERT_EQ(bvh.values.size(), 28u);
  EXPECT_EQ(bvh.values[0], 1);
  EXPECT_EQ(bvh.values[13], 1.5);
  EXPECT_EQ(bvh.values[27], -1.5);
}

TEST(Bvh, AcceptsCrlfTabsBomNumberFormsAndTrailingBlankLines) {
  std::string text = "\xEF\xBB\xBF";
  for (char c : kSmall) {
    if (c == '\n') text += " \t\r\n";
    else if (c == ' ') text += "\t";
    else text += c;
  }
  text = replace(text, "Frame\tTime:\t0.0333333", "Frame Time:\t\t.0333333");
  text = replace(text, "1\t2\t3\t10", "+1\t2.0e0\t3E+00\t1e1");
  text += "\r\n\r\n   \t\n";
  const BvhFile a = parse_bvh(text, "crlf.bvh");
  const BvhFile b = parse_bvh(kSmall, "small.bvh");
  expect_same_structure(a, b);
  EXPECT_EQ(a.values, b.values);
}

TEST(Bvh, AcceptsLowercaseKeywordsBracesOnNameLineAndColonVariants) {
  const std::string text =
      "hierarchy\nroot Hips {\noffset 0 0 0\nchannels 3 Xposition Yposition Zposition\n"
      "joint Left Arm {\n OFFSET 1 0 0\n CHANNELS 1 zrotation\n end site { OFFSET 0 1 0 } }\n}\n"
      "Motion\nFrames:2\nFrame Time:0.5\n1 2 3 4\n5 6 7 8\n";
  const BvhFile bvh = parse_bvh(text, "lower.bvh");
  EXPECT_EQ(bvh.skeleton.joint_names, (std::vector<std::string>{"Hips", "Left Arm"}));
  EXPECT_EQ(bvh.num_frames, 2);
  EXPECT_EQ(bvh.frame_time_s, 0.5);
  EXPECT_EQ(bvh.values, (std::vector<double>{1, 2, 3, 4, 5, 6, 7, 8}));
  ASSERT_EQ(bvh.skeleton.end_sites.size(), 1u);
}

TEST(Bvh, AcceptsFramesWrappedOverLines) {
  const std::string text = small_header(2) + "1 2 3 10 20\n30 5 6 7 8 9 10 15 1.5 -1 -2\n-3 -10 -20 -30 -5 -6 -7 -8 -9 -10 -15 -1.5";
  const BvhFile bvh = parse_bvh(text, "wrapped.bvh");
  EXPECT_EQ(bvh.values, parse_bvh(kSmall, "small.bvh").values);
}

// The motion scanner must give exactly strtod's correctly rounded doubles for every spelling.
TEST(Bvh, MotionNumbersAreParsedExactly) {
  std::mt19937_64 rng(99);
  std::vector<std::string> tokens = {"0", "-0", "0.0", ".5", "-.5", "+.5", "1.", "5.1072e-06", "-1.3905E-06", "1e22",
                                     "1e23", "1e-22", "1e-23", "123456789012345", "1234567890123456789", "9007199254740993",
                                     "0.1", "0.30000000000000004", "1e300", "-2.2250738585072014e-308", "4.9e-324",
                                     "0.000000000000000000000000001", "1234.5678e-3", "+7e+2"};
  for (int i = 0; i < 3000; ++i) {
    const double v = std::ldexp(static_cast<double>(rng() >> 11) * (rng() % 2 ? 1 : -1), static_cast<int>(rng() % 80) - 60);
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.*g", 1 + static_cast<int>(rng() % 17), v);
    tokens.push_back(buffer);
    std::snprintf(buffer, sizeof(buffer), "%.*f", static_cast<int>(rng() % 12), v);
    tokens.push_back(buffer);
  }
  std::string text = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: " +
                     std::to_string(tokens.size()) + "\nFrame Time: 0.1\n";
  for (const std::string& t : tokens) text += t + "\n";
  const BvhFile bvh = parse_bvh(text, "numbers.bvh");
  ASSERT_EQ(bvh.values.size(), tokens.size());
  for (size_t i = 0; i < tokens.size(); ++i) {
    const double expected = std::strtod(tokens[i].c_str(), nullptr);
    EXPECT_EQ(bvh.values[i], expected) << tokens[i];
    EXPECT_EQ(std::signbit(bvh.values[i]), std::signbit(expected)) << tokens[i];
  }
}

TEST(Bvh, ZeroFramesIsAValidEmptyMotion) {
  const BvhFile bvh = parse_bvh(small_header(0), "empty_motion.bvh");
  EXPECT_EQ(bvh.num_frames, 0);
  EXPECT_TRUE(bvh.values.empty());
  const Clip clip = to_clip(bvh);
  EXPECT_EQ(clip.motion.num_frames, 0);
  EXPECT_EQ(clip.skeleton.num_joints(), 4);
  const BvhFile again = parse_bvh(format_bvh(bvh), "again.bvh");
  expect_same_structure(bvh, again);
}

TEST(Bvh, JointWithoutChannelsIsAllowed) {
  const std::string text =
      "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
      "JOINT B\n{\nOFFSET 0 1 0\nJOINT C\n{\nOFFSET 0 1 0\nCHANNELS 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 90 0\n";
  const BvhFile bvh = parse_bvh(text, "nochan.bvh");
  EXPECT_TRUE(bvh.channels[1].empty());
  EXPECT_TRUE(bvh.channels[2].empty());
  const Clip clip = to_clip(bvh);
  EXPECT_TRUE(clip.motion.rotation(0, 1).isApprox(Eigen::Quaterniond::Identity()));
  const BvhFile again = parse_bvh(format_bvh(bvh), "again.bvh");
  EXPECT_EQ(again.channels, bvh.channels);
}

// --- Malformed input --------------------------------------------------------------------------

TEST(Bvh, RejectsEmptyAndGarbageFiles) {
  expect_parse_error("", 1, "empty");
  expect_parse_error(" \n\t\r\n", 3, "empty");
  expect_parse_error(std::string("\x00\x01\xff\xfe garbage", 12), 1, "expected HIERARCHY");  // 4 bytes + 8
  expect_parse_error("ROOT Hips\n{\n}", 1, "expected HIERARCHY");
  expect_parse_error("HIERARCHY\nJOINT Hips\n", 2, "expected ROOT");
  expect_parse_error("HIERARCHY\nROOT\n{\n", 2, "joint name");
  expect_parse_error("HIERARCHY\nROOT Hips\nOFFSET 0 0 0\n", 3, "expected '{'");
}

TEST(Bvh, RejectsMissingMotionAndBadHeaders) {
  const size_t motion = kSmall.find("MOTION");
  const std::string hierarchy = kSmall.substr(0, motion);
  const int motion_line = line_of(kSmall, "MOTION");
  expect_parse_error(hierarchy, motion_line, "expected MOTION");
  expect_parse_error(hierarchy + "FOO\n", motion_line, "expected MOTION");
  expect_parse_error(hierarchy + "MOTION\n", motion_line + 1, "Frames:");
  expect_parse_error(hierarchy + "MOTION\nFrame: 2\n", motion_line + 1, "expected 'Frames:'");
  expect_parse_error(hierarchy + "MOTION\nFrames: two\n", motion_line + 1, "whole number");
  expect_parse_error(hierarchy + "MOTION\nFrames: 2.5\n", motion_line + 1, "whole number");
  expect_parse_error(hierarchy + "MOTION\nFrames: -1\n", motion_line + 1, "negative");
  expect_parse_error(hierarchy + "MOTION\nFrames: 1000000000000\n", motion_line + 1, "too large");
  expect_parse_error(hierarchy + "MOTION\nFrames: 99999999999999999999999999\n", motion_line + 1, "too large");
  expect_parse_error(hierarchy + "MOTION\nFrames: 2\n", motion_line + 2, "Frame Time:");
  expect_parse_error(hierarchy + "MOTION\nFrames: 2\nFrame Time:", motion_line + 2, "value after");
  for (const char* bad : {"0", "-0.1", "nan", "inf", "abc", "1e999"})
    expect_parse_error(hierarchy + "MOTION\nFrames: 0\nFrame Time: " + bad + "\n", motion_line + 2, "positive");
}

TEST(Bvh, RejectsBadChannels) {
  const int line = line_of(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 4 Zrotation Yrotation Xrotation"),
                     line + 1, "lists only 3 channel names");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 2 Zrotation Yrotation Xrotation"),
                     line, "more than 2 channel names");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 7 Zrotation Yrotation Xrotation"),
                     line, "0 to 6");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 1000000000000 Zrotation"),
                     line, "number of channels");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS -3 Zrotation"), line, "0 to 6");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS x Zrotation"), line,
                     "number of channels");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Wrotation Xrotation"),
                     line, "unknown channel 'Wrotation'");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Zrotation Xrotation"),
                     line, "repeats");
  expect_parse_error(replace(kSmall, "CHANNELS 3 Zrotation Yrotation Xrotation",
                             "CHANNELS 3 Zrotation Yrotation Xrotation\nCHANNELS 1 Xposition"),
                     line + 1, "second CHANNELS");
  expect_parse_error(replace(kSmall, "        OFFSET 0 2 0\n", "        OFFSET 0 2 0\n CHANNELS 1 Xrotation\n"),
                     line_of(kSmall, "        OFFSET 0 2 0") + 1, "End Site");
}

TEST(Bvh, RejectsBadHierarchyStructure) {
  // Missing closing brace: the file ends inside a joint (MOTION is reached first).
  expect_parse_error(replace(kSmall, "  }\n  JOINT Leg", "  JOINT Leg"), line_of(kSmall, "MOTION") - 1, "no closing '}'");
  expect_parse_error(kSmall.substr(0, kSmall.find("MOTION")), 0, "expected MOTION");
  expect_parse_error("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n", 5, "unexpected end of file inside joint 'A'");
  // An extra closing brace.
  expect_parse_error(replace(kSmall, "}\nMOTION", "}\n}\nMOTION"), line_of(kSmall, "MOTION"), "unbalanced");
  expect_parse_error(replace(kSmall, "JOINT Leg", "JOINT Spine"), line_of(kSmall, "JOINT Leg"), "duplicate joint name 'Spine'");
  expect_parse_error(replace(kSmall, "}\nMOTION", "}\nROOT B\n{\nOFFSET 0 0 0\n}\nMOTION"), line_of(kSmall, "MOTION"),
                     "second ROOT");
  expect_parse_error(replace(kSmall, "    OFFSET 1 -1 0\n", ""), 0, "joint 'Leg' has no OFFSET");
  expect_parse_error(replace(kSmall, "    OFFSET 1 -1 0\n", "    OFFSET 1 -1\n"), line_of(kSmall, "OFFSET 1 -1 0") + 1,
                     "OFFSET coordinate");
  expect_parse_error(replace(kSmall, "    OFFSET 1 -1 0\n", "    OFFSET 1 nan 0\n"), line_of(kSmall, "OFFSET 1 -1 0"),
                     "non-finite");
  expect_parse_error(replace(kSmall, "    OFFSET 1 -1 0\n", "    OFFSET 1 -1 0\n    OFFSET 1 -1 0\n"),
                     line_of(kSmall, "OFFSET 1 -1 0") + 1, "second OFFSET");
  expect_parse_error(replace(kSmall, "  JOINT Leg", "  BONE Leg"), line_of(kSmall, "JOINT Leg"), "unexpected 'BONE'");
}

TEST(Bvh, RejectsDeepNestingWithoutOverflowingTheStack) {
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\n";
  const int depth = 200000;
  for (int i = 1; i < depth; ++i) text += "JOINT j" + std::to_string(i) + "\n{\nOFFSET 0 1 0\n";
  expect_parse_error(text, 0, "deeper than 1024");
  // Just under the limit parses.
  std::string ok = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n";
  for (int i = 1; i < kBvhMaxDepth; ++i) ok += "JOINT j" + std::to_string(i) + "\n{\nOFFSET 0 1 0\n";
  for (int i = 0; i < kBvhMaxDepth; ++i) ok += "}\n";
  ok += "MOTION\nFrames: 1\nFrame Time: 0.1\n45\n";
  const BvhFile bvh = parse_bvh(ok, "deep.bvh");
  EXPECT_EQ(bvh.skeleton.num_joints(), kBvhMaxDepth);
  EXPECT_EQ(parse_bvh(format_bvh(bvh), "deep2.bvh").skeleton.parents, bvh.skeleton.parents);
}

TEST(Bvh, RejectsTooManyJoints) {
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\n";
  for (int i = 1; i <= kBvhMaxJoints; ++i) text += "JOINT j" + std::to_string(i) + " { OFFSET 0 1 0 }\n";
  text += "}\nMOTION\nFrames: 0\nFrame Time: 0.1\n";
  expect_parse_error(text, 0, "more than 10000 joints");
}

TEST(Bvh, RejectsBadMotionValuesWithTheirLine) {
  const std::string header = small_header(2);
  const int first = line_of(kSmall, "1 2 3 10");
  const std::string row = "1 2 3 10 20 30 5 6 7 8 9 10 15 1.5\n";
  expect_parse_error(header + row + "1 2 3 10 20 30 5 x 7 8 9 10 15 1.5\n", first + 1, "expected a number in the motion data, found 'x'");
  expect_parse_error(header + row + "1 2 3 10 20 30 5 6- 7 8 9 10 15 1.5\n", first + 1, "found '6-'");
  expect_parse_error(header + row + "1 2 3 10 20 30 5 nan 7 8 9 10 15 1.5\n", first + 1, "non-finite value 'nan'");
  expect_parse_error(header + row + "1 2 3 10 20 30 5 -inf 7 8 9 10 15 1.5\n", first + 1, "non-finite");
  expect_parse_error(header + row + "1 2 3 10 20 30 5 1e999 7 8 9 10 15 1.5\n", first + 1, "out of range");
  expect_parse_error(header + row + "1 2 3 10 20 30 5 6 7 8 9 10 15\n", first + 1, "has 13 values, expected 14");
  expect_parse_error(header + "1 2 3 10 20 30 5 6 7 8 9 10 15 1.5 99\n" + row, first, "has 15 values, expected 14");
  expect_parse_error(header + row, first, "only 1 frames");
  expect_parse_error(header, 0, "only 0 frames");
  expect_parse_error(header + row + row + row, first + 2, "more motion data");
  expect_parse_error(header + row + row + "extra words\n", first + 2, "found 'extra'");
}

TEST(Bvh, AbsurdFrameCountFailsWithoutAllocating) {
  // 2e9 frames x 14 channels would need 224 GB; the parser must notice the data is missing.
  expect_parse_error(small_header(2000000000) + "1 2 3 10 20 30 5 6 7 8 9 10 15 1.5\n", 0, "only 1 frames");
  const std::string no_channels = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 2000000000\nFrame Time: 0.1\n";
  expect_parse_error(no_channels, 7, "no joint has CHANNELS");
}

// Every prefix of a valid file either parses or gives a ParseError: never a crash or another error.
TEST(Bvh, TruncationAtEveryOffsetGivesParseErrorOrValidFile) {
  int parsed = 0;
  for (size_t n = 0; n <= kSmall.size(); ++n) {
    try {
      const BvhFile bvh = parse_bvh(kSmall.substr(0, n), "cut.bvh");
      EXPECT_EQ(bvh.values.size(), static_cast<size_t>(bvh.num_frames) * bvh.num_channels());
      ++parsed;
    } catch (const ParseError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("cut.bvh:", 0), 0u);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "offset " << n << ": unexpected exception " << e.what();
    }
  }
  // Only cuts inside or after the last number parse (e.g. "1." or "1.5" with or without "\n").
  EXPECT_GE(parsed, 2);
  EXPECT_LE(parsed, 4);
}

// Random byte corruption: only ParseError or a consistent parse.
TEST(Bvh, RandomCorruptionGivesParseErrorOrValidFile) {
  std::mt19937 rng(12345);
  const std::string alphabet = std::string("{}\n\r\t -+.eE0123456789xyzXYZJOINTEndSiteOFFSETCHANNELS") + '\0' + "\xff";
  for (int trial = 0; trial < 3000; ++trial) {
    std::string text = kSmall;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < edits; ++k) {
      const size_t pos = rng() % text.size();
      const char c = alphabet[rng() % alphabet.size()];
      switch (rng() % 3) {
        case 0: text[pos] = c; break;
        case 1: text.insert(text.begin() + static_cast<std::ptrdiff_t>(pos), c); break;
        default: text.erase(pos, 1 + rng() % 8); break;
      }
    }
    try {
      const BvhFile bvh = parse_bvh(text, "fuzz.bvh");
      EXPECT_EQ(bvh.values.size(), static_cast<size_t>(bvh.num_frames) * bvh.num_channels());
      EXPECT_NO_THROW(to_clip(bvh));
      EXPECT_NO_THROW(format_bvh(bvh));
    } catch (const ParseError&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "trial " << trial << ": unexpected exception " << e.what();
    }
  }
}

// --- Files ------------------------------------------------------------------------------------

TEST(Bvh, ReadBvhNamesThePath) {
  const fs::path dir = make_temp_dir("bvh_read");
  const std::string missing = (dir / "missing.bvh").string();
  try {
    read_bvh(missing);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string bad = (dir / "bad.bvh").string();
  write_file_atomically(bad, "HIERARCHY\nROOT A\n{\n");
  try {
    read_bvh(bad);
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), bad);
    EXPECT_EQ(e.line(), 4);
  }
  EXPECT_THROW(read_bvh(dir.string()), Error);  // a directory
  fs::remove_all(dir);
}

TEST(Bvh, WriteThenReadRoundTrip) {
  const fs::path dir = make_temp_dir("bvh_write");
  const BvhFile original = parse_bvh(kSmall, "small.bvh");
  const std::string path = (dir / "out.bvh").string();
  write_bvh(path, original);
  const BvhFile again = read_bvh(path);
  expect_same_structure(original, again);
  EXPECT_EQ(again.values, original.values);
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 1u);  // no temporary file left behind
  fs::remove_all(dir);
}

TEST(Bvh, FormatKeepsSignificantDigits) {
  BvhFile bvh = parse_bvh(kSmall, "small.bvh");
  bvh.values[0] = 123.456789012345;
  bvh.values[1] = -1.23456789e-7;
  bvh.values[2] = 9.87654321e12;
  const BvhFile again = parse_bvh(format_bvh(bvh), "again.bvh");
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(again.values[i], bvh.values[i], 1e-8 * std::abs(bvh.values[i]));
  EXPECT_EQ(parse_bvh(format_bvh(bvh, 17), "exact.bvh").values, bvh.values);
}

TEST(Bvh, FormatRejectsInconsistentFiles) {
  BvhFile bvh = parse_bvh(kSmall, "small.bvh");
  BvhFile short_values = bvh;
  short_values.values.pop_back();
  EXPECT_THROW(format_bvh(short_values), Error);
  BvhFile nan_value = bvh;
  nan_value.values[3] = std::nan("");
  EXPECT_THROW(format_bvh(nan_value), Error);
  // Joint 3 (Leg, child of the root) placed before Spine's child Head: not a pre-order.
  BvhFile reordered = bvh;
  std::swap(reordered.skeleton.joint_names[2], reordered.skeleton.joint_names[3]);
  std::swap(reordered.skeleton.offsets[2], reordered.skeleton.offsets[3]);
  reordered.skeleton.parents = {-1, 0, 0, 1};
  reordered.skeleton.end_sites.clear();
  EXPECT_THROW(format_bvh(reordered), Error);
  for (const char* name : {"", "a{b", "a}", "two\nlines", " lead", "trail ", "double  space", "tab\there"}) {
    BvhFile renamed = bvh;
    renamed.skeleton.joint_names[1] = name;
    EXPECT_THROW(format_bvh(renamed), Error) << name;
  }
  BvhFile spaced = bvh;
  spaced.skeleton.joint_names[1] = "Left Upper Arm";
  EXPECT_EQ(parse_bvh(format_bvh(spaced), "spaced.bvh").skeleton.joint_names[1], "Left Upper Arm");
}

// --- Conversion to and from clips -------------------------------------------------------------

TEST(Bvh, ToClipComposesRotationChannelsInFileOrder) {
  const BvhFile bvh = parse_bvh(kSmall, "small.bvh");
  const Clip clip = to_clip(bvh);
  const Motion& m = clip.motion;
  EXPECT_NEAR(m.fps, 1 / 0.0333333, 1e-9);
  ASSERT_EQ(m.num_frames, 2);
  ASSERT_EQ(m.num_joints, 4);
  EXPECT_NO_THROW(m.validate());
  // Root: ZXY with angles 10, 20, 30 degrees equals EulerOrder::kZXY.
  const Eigen::Quaterniond root = quat_from_euler(Eigen::Vector3d(10, 20, 30) * kPi / 180, EulerOrder::kZXY);
  EXPECT_LT(geodesic_angle(m.rotation(0, 0), root), 1e-12);
  EXPECT_LT(geodesic_angle(m.rotation(0, 1), product({{2, 5}, {1, 6}, {0, 7}})), 1e-12);
  EXPECT_LT(geodesic_angle(m.rotation(0, 2), product({{0, 8}, {1, 9}, {2, 10}})), 1e-12);
  EXPECT_LT(geodesic_angle(m.rotation(0, 3), product({{1, 15}})), 1e-12);
  EXPECT_LT(geodesic_angle(m.rotation(1, 1), product({{2, -5}, {1, -6}, {0, -7}})), 1e-12);
  // Positions: the root's from its channels; Leg's X from its channel, Y and Z from its OFFSET.
  EXPECT_EQ(m.translation(0, 0), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(m.translation(1, 0), Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(m.translation(0, 1), Eigen::Vector3d(0, 10, 0));
  EXPECT_EQ(m.translation(0, 3), Eigen::Vector3d(1.5, -1, 0));
  EXPECT_EQ(m.translation(1, 3), Eigen::Vector3d(-1.5, -1, 0));
}

TEST(Bvh, ToClipHandlesAllSixEulerOrders) {
  const char* orders[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  for (const char* order : orders) {
    std::string channels;
    for (int i = 0; i < 3; ++i) channels += std::string(" ") + order[i] + "rotation";
    const std::string text = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3" + channels +
                             "\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n-40 70 130\n";
    const Clip clip = to_clip(parse_bvh(text, "order.bvh"));
    const Eigen::Quaterniond expected = quat_from_euler(Eigen::Vector3d(-40, 70, 130) * kPi / 180, *parse_euler_order(order));
    EXPECT_LT(geodesic_angle(clip.motion.rotation(0, 0), expected), 1e-12) << order;
  }
}

TEST(Bvh, ToClipKeepsQuaternionsInOneHemisphere) {
  std::string text = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\n}\nMOTION\nFrames: 73\nFrame Time: 0.1\n";
  for (int t = 0; t < 73; ++t) text += std::to_string(t * 10) + "\n";
  const Clip clip = to_clip(parse_bvh(text, "spin.bvh"));
  for (int t = 1; t < 73; ++t) EXPECT_GT(clip.motion.rotation(t, 0).dot(clip.motion.rotation(t - 1, 0)), 0.99);
}

// Random rotations and translations on the small skeleton.
Clip random_clip(int num_frames, unsigned seed) {
  const BvhFile bvh = parse_bvh(kSmall, "small.bvh");
  Clip clip;
  clip.skeleton = bvh.skeleton;
  clip.motion = Motion::rest(clip.skeleton, num_frames, 60.0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  for (int t = 0; t < num_frames; ++t)
    for (int j = 0; j < clip.skeleton.num_joints(); ++j) {
      clip.motion.rotation(t, j) = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized();
      if (j == 0) clip.motion.translation(t, j) = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)) * 50;
    }
  return clip;
}

TEST(Bvh, FromClipWithoutTemplateUsesCmuLayoutAndRoundTrips) {
  Clip clip = random_clip(50, 7);
  clip.motion.translation(10, 2) += Eigen::Vector3d(0, 0.25, 0);  // animated non-root translation
  const BvhFile bvh = from_clip(clip);
  const BvhChannelLayout zyx = {BvhChannel::kZrotation, BvhChannel::kYrotation, BvhChannel::kXrotation};
  BvhChannelLayout root = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
  root.insert(root.end(), zyx.begin(), zyx.end());
  EXPECT_EQ(bvh.channels[0], root);
  EXPECT_EQ(bvh.channels[1], zyx);
  EXPECT_EQ(bvh.channels[2], root);  // gained position channels
  EXPECT_EQ(bvh.channels[3], zyx);
  EXPECT_NEAR(bvh.frame_time_s, 1.0 / 60, 1e-15);
  const Clip back = to_clip(parse_bvh(format_bvh(bvh), "cmu_layout.bvh"));
  ASSERT_EQ(back.motion.num_frames, 50);
  EXPECT_NEAR(back.motion.fps, 60, 1e-9);
  for (int t = 0; t < 50; ++t)
    for (int j = 0; j < 4; ++j) {
      EXPECT_LT(geodesic_angle(back.motion.rotation(t, j), clip.motion.rotation(t, j)), 1e-6);
      EXPECT_LT((back.motion.translation(t, j) - clip.motion.translation(t, j)).norm(), 1e-5);
    }
}

TEST(Bvh, FromClipWithTemplateKeepsLayoutAndRotations) {
  const BvhFile original = parse_bvh(kSmall, "small.bvh");
  const Clip clip = to_clip(original);
  const BvhFile bvh = from_clip(clip, &original);
  EXPECT_EQ(bvh.channels, original.channels);
  const Clip back = to_clip(bvh);
  for (int t = 0; t < 2; ++t)
    for (int j = 0; j < 4; ++j) {
      EXPECT_LT(geodesic_angle(back.motion.rotation(t, j), clip.motion.rotation(t, j)), 1e-9);
      EXPECT_LT((back.motion.translation(t, j) - clip.motion.translation(t, j)).norm(), 1e-12);
    }
  // The single-axis joint gets its angle back exactly; Euler triples match the file's.
  for (size_t i = 0; i < bvh.values.size(); ++i) EXPECT_NEAR(bvh.values[i], original.values[i], 1e-9) << i;

  // Random full rotations through every channel layout of the template (3-axis joints exact).
  Clip random = random_clip(30, 11);
  for (int t = 0; t < 30; ++t) random.motion.rotation(t, 3) = quat_about_axis(1, 0.1 * t - 1.0);
  const Clip random_back = to_clip(parse_bvh(format_bvh(from_clip(random, &original)), "t.bvh"));
  for (int t = 0; t < 30; ++t)
    for (int j = 0; j < 4; ++j)
      EXPECT_LT(geodesic_angle(random_back.motion.rotation(t, j), random.motion.rotation(t, j)), 1e-6) << t << " " << j;
}

TEST(Bvh, FromClipRejectsMismatchedTemplate) {
  const BvhFile original = parse_bvh(kSmall, "small.bvh");
  Clip clip = to_clip(original);
  BvhFile other = original;
  other.skeleton.joint_names[1] = "Chest";
  EXPECT_THROW(from_clip(clip, &other), Error);
  clip.motion.num_joints = 3;
  EXPECT_THROW(from_clip(clip), Error);
}

TEST(Bvh, FromClipKeepsEulerAnglesContinuous) {
  // Spin about Z for two turns while tilting about Y (the middle axis of ZYX) past 90 degrees,
  // where the principal Euler solution would jump (never exactly 90: gimbal lock is ambiguous).
  BvhFile layout = parse_bvh("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n}\n"
                             "MOTION\nFrames: 0\nFrame Time: 0.1\n",
                             "layout.bvh");
  Clip clip;
  clip.skeleton = layout.skeleton;
  const int frames = 361;
  clip.motion = Motion::rest(clip.skeleton, frames, 30);
  for (int t = 0; t < frames; ++t)
    clip.motion.rotation(t, 0) = product({{2, 2.0 * t}, {1, 0.5 * t + 0.25}, {0, 10 * std::sin(t * 0.05)}});
  const BvhFile bvh = from_clip(clip, &layout);
  for (int t = 1; t < frames; ++t)
    for (int c = 0; c < 3; ++c)
      EXPECT_LT(std::abs(bvh.values[static_cast<size_t>(t) * 3 + c] - bvh.values[static_cast<size_t>(t - 1) * 3 + c]), 5.0)
          << "frame " << t << " channel " << c;
  // The Z angle keeps accumulating past 360 degrees instead of wrapping.
  EXPECT_NEAR(std::abs(bvh.values[static_cast<size_t>(frames - 1) * 3] - bvh.values[0]), 720.0, 1.0);
  const Clip back = to_clip(bvh);
  for (int t = 0; t < frames; ++t) EXPECT_LT(geodesic_angle(back.motion.rotation(t, 0), clip.motion.rotation(t, 0)), 1e-7);
}

TEST(Bvh, FromClipStaysContinuousThroughGimbalLock) {
  BvhFile layout = parse_bvh("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n}\n"
                             "MOTION\nFrames: 0\nFrame Time: 0.1\n",
                             "layout.bvh");
  Clip clip;
  clip.skeleton = layout.skeleton;
  const int frames = 11;
  clip.motion = Motion::rest(clip.skeleton, frames, 30);
  for (int t = 0; t < frames; ++t)  // the middle angle is exactly 90 degrees at t = 5
    clip.motion.rotation(t, 0) = quat_from_euler(Eigen::Vector3d(30 + t, 80 + 2 * t, 20 + t) * kPi / 180, EulerOrder::kZYX);
  const BvhFile bvh = from_clip(clip, &layout);
  for (int t = 1; t < frames; ++t)
    for (int c = 0; c < 3; ++c)
      EXPECT_LT(std::abs(bvh.values[static_cast<size_t>(t) * 3 + c] - bvh.values[static_cast<size_t>(t - 1) * 3 + c]), 5.0)
          << "frame " << t << " channel " << c;
  const Clip back = to_clip(bvh);
  for (int t = 0; t < frames; ++t) EXPECT_LT(geodesic_angle(back.motion.rotation(t, 0), clip.motion.rotation(t, 0)), 1e-6) << t;
}

}  // namespace
}  // namespace mosyn::io
